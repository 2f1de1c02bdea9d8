// PipelineBase: push-descriptor set layout, pipeline layout, and the checked bind.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"

namespace gauss::vk {
namespace {

VkDescriptorType descriptor_type(DescriptorKind kind) {
  switch (kind) {
    case DescriptorKind::StorageBuffer: return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    case DescriptorKind::UniformBuffer: return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case DescriptorKind::StorageImage: return VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    case DescriptorKind::SampledImage: return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  }
  return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
}

const char* kind_name(DescriptorKind kind) {
  switch (kind) {
    case DescriptorKind::StorageBuffer: return "storage buffer";
    case DescriptorKind::UniformBuffer: return "uniform buffer";
    case DescriptorKind::StorageImage: return "storage image";
    case DescriptorKind::SampledImage: return "sampled image";
  }
  return "?";
}

bool layout_suits(DescriptorKind kind, VkImageLayout layout) {
  if (kind == DescriptorKind::StorageImage) return layout == VK_IMAGE_LAYOUT_GENERAL;
  return layout == VK_IMAGE_LAYOUT_GENERAL || layout == VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL ||
         layout == VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL || layout == VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL ||
         layout == VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
}

}  // namespace

PipelineBase::~PipelineBase() { destroy(); }

PipelineBase::PipelineBase(PipelineBase&& other) noexcept
    : context_(std::exchange(other.context_, nullptr)),
      name_(std::move(other.name_)),
      bindings_(std::move(other.bindings_)),
      push_constant_size_(std::exchange(other.push_constant_size_, 0)),
      stages_(std::exchange(other.stages_, 0)),
      bind_point_(other.bind_point_),
      set_layout_(std::exchange(other.set_layout_, VK_NULL_HANDLE)),
      layout_(std::exchange(other.layout_, VK_NULL_HANDLE)),
      pipeline_(std::exchange(other.pipeline_, VK_NULL_HANDLE)) {}

PipelineBase& PipelineBase::operator=(PipelineBase&& other) noexcept {
  if (this != &other) {
    destroy();
    context_ = std::exchange(other.context_, nullptr);
    name_ = std::move(other.name_);
    bindings_ = std::move(other.bindings_);
    push_constant_size_ = std::exchange(other.push_constant_size_, 0);
    stages_ = std::exchange(other.stages_, 0);
    bind_point_ = other.bind_point_;
    set_layout_ = std::exchange(other.set_layout_, VK_NULL_HANDLE);
    layout_ = std::exchange(other.layout_, VK_NULL_HANDLE);
    pipeline_ = std::exchange(other.pipeline_, VK_NULL_HANDLE);
  }
  return *this;
}

void PipelineBase::destroy() noexcept {
  if (context_ == nullptr) return;
  (void)vkDeviceWaitIdle(context_->device());
  if (pipeline_) vkDestroyPipeline(context_->device(), pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(context_->device(), layout_, nullptr);
  if (set_layout_) vkDestroyDescriptorSetLayout(context_->device(), set_layout_, nullptr);
  pipeline_ = VK_NULL_HANDLE;
  layout_ = VK_NULL_HANDLE;
  set_layout_ = VK_NULL_HANDLE;
  context_ = nullptr;
}

Status PipelineBase::create_layout(Context& context, const std::string& name,
                                   std::span<const DescriptorBinding> bindings, std::uint32_t push_constant_size,
                                   VkShaderStageFlags stages) {
  context_ = &context;
  name_ = name;
  bindings_.assign(bindings.begin(), bindings.end());
  push_constant_size_ = push_constant_size;
  stages_ = stages;
  const std::string what = "pipeline '" + name + "'";
  if (push_constant_size % 4 != 0 || push_constant_size > context.limits().maxPushConstantsSize) {
    return Error{what + ": push constant size " + std::to_string(push_constant_size) +
                 " must be a multiple of 4 and at most " + std::to_string(context.limits().maxPushConstantsSize)};
  }
  std::vector<VkDescriptorSetLayoutBinding> vk_bindings;
  for (std::size_t i = 0; i < bindings_.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (bindings_[j].binding == bindings_[i].binding) {
        return Error{what + ": binding " + std::to_string(bindings_[i].binding) + " declared twice"};
      }
    }
    VkDescriptorSetLayoutBinding b{};
    b.binding = bindings_[i].binding;
    b.descriptorType = descriptor_type(bindings_[i].kind);
    b.descriptorCount = 1;
    b.stageFlags = stages;
    vk_bindings.push_back(b);
  }
  if (vk_bindings.size() > 32) return Error{what + ": more than 32 bindings (maxPushDescriptors)"};
  VkDescriptorSetLayoutCreateInfo sci{};
  sci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  sci.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
  sci.bindingCount = static_cast<std::uint32_t>(vk_bindings.size());
  sci.pBindings = vk_bindings.data();
  GAUSS_VK_TRY(vkCreateDescriptorSetLayout(context.device(), &sci, nullptr, &set_layout_));

  VkPushConstantRange pcr{stages, 0, push_constant_size};
  VkPipelineLayoutCreateInfo lci{};
  lci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  lci.setLayoutCount = 1;
  lci.pSetLayouts = &set_layout_;
  lci.pushConstantRangeCount = push_constant_size > 0 ? 1 : 0;
  lci.pPushConstantRanges = &pcr;
  GAUSS_VK_TRY(vkCreatePipelineLayout(context.device(), &lci, nullptr, &layout_));
  return Ok{};
}

Status PipelineBase::bind(VkCommandBuffer cmd, std::span<const Resource> resources) const {
  if (!valid()) return Error{"bind of an empty pipeline"};
  // Error texts are built only on failure: bind runs for every pass of every frame.
  auto what = [&] { return "pipeline '" + name_ + "'"; };
  const VkPhysicalDeviceLimits& limits = context_->limits();
  std::vector<VkWriteDescriptorSet> writes;
  std::vector<VkDescriptorBufferInfo> buffer_infos;
  std::vector<VkDescriptorImageInfo> image_infos;
  // Reserved up front: the writes point into these vectors.
  buffer_infos.reserve(resources.size());
  image_infos.reserve(resources.size());

  for (const DescriptorBinding& decl : bindings_) {
    const auto count = std::count_if(resources.begin(), resources.end(),
                                     [&](const Resource& r) { return r.binding == decl.binding; });
    if (count != 1) {
      return Error{what() + ": binding " + std::to_string(decl.binding) + " (" + kind_name(decl.kind) + ") given " +
                   std::to_string(count) + " times, expected once"};
    }
  }
  for (const Resource& r : resources) {
    const auto decl = std::find_if(bindings_.begin(), bindings_.end(),
                                   [&](const DescriptorBinding& d) { return d.binding == r.binding; });
    if (decl == bindings_.end()) return Error{what() + ": binding " + std::to_string(r.binding) + " is not declared"};
    auto where = [&] { return what() + " binding " + std::to_string(r.binding) + " (" + kind_name(decl->kind) + ")"; };
    VkWriteDescriptorSet w{};
    w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w.dstBinding = r.binding;
    w.descriptorCount = 1;
    w.descriptorType = descriptor_type(decl->kind);
    const bool wants_buffer = decl->kind == DescriptorKind::StorageBuffer || decl->kind == DescriptorKind::UniformBuffer;
    if (wants_buffer) {
      if (r.buffer == nullptr || !r.buffer->valid()) return Error{where() + ": needs a (created) buffer"};
      const VkDeviceSize range = r.range == 0 ? (r.offset <= r.buffer->size() ? r.buffer->size() - r.offset : 0) : r.range;
      if (range == 0) return Error{where() + ": empty range at offset " + std::to_string(r.offset) + " of buffer '" + r.buffer->name() + "'"};
      if (auto st = r.buffer->check_range(r.offset, range); !st) return Error{where() + ": " + st.message()};
      const bool storage = decl->kind == DescriptorKind::StorageBuffer;
      const VkDeviceSize max_range = storage ? limits.maxStorageBufferRange : limits.maxUniformBufferRange;
      if (range > max_range) {
        return Error{where() + ": buffer '" + r.buffer->name() + "' range of " + std::to_string(range) +
                     " bytes exceeds " + (storage ? "maxStorageBufferRange " : "maxUniformBufferRange ") +
                     std::to_string(max_range) + "; bind it in pieces"};
      }
      const VkDeviceSize align =
          storage ? limits.minStorageBufferOffsetAlignment : limits.minUniformBufferOffsetAlignment;
      if (align > 0 && r.offset % align != 0) {
        return Error{where() + ": offset " + std::to_string(r.offset) + " is not a multiple of " + std::to_string(align)};
      }
      buffer_infos.push_back({r.buffer->handle(), r.offset, range});
      w.pBufferInfo = &buffer_infos.back();
    } else {
      if (r.image == nullptr || !r.image->valid()) return Error{where() + ": needs a (created) image"};
      if (!layout_suits(decl->kind, r.image->layout())) {
        return Error{where() + ": image '" + r.image->name() + "' is in layout " + std::to_string(r.image->layout()) +
                     (decl->kind == DescriptorKind::StorageImage ? ", needs GENERAL" : ", needs a read-only layout") +
                     " (transition it before bind)"};
      }
      const VkSampler sampler = decl->kind == DescriptorKind::SampledImage ? context_->nearest_sampler() : VK_NULL_HANDLE;
      image_infos.push_back({sampler, r.image->view(), r.image->layout()});
      w.pImageInfo = &image_infos.back();
    }
    writes.push_back(w);
  }
  vkCmdBindPipeline(cmd, bind_point_, pipeline_);
  if (!writes.empty()) {
    vkCmdPushDescriptorSetKHR(cmd, bind_point_, layout_, 0, static_cast<std::uint32_t>(writes.size()), writes.data());
  }
  return Ok{};
}

void PipelineBase::push_constants(VkCommandBuffer cmd, const void* data, std::uint32_t size) const {
  if (size > push_constant_size_ || size % 4 != 0) {
    std::fprintf(stderr, "pipeline '%s': push_constants of %u bytes, declared %u (multiple of 4 required)\n",
                 name_.c_str(), size, push_constant_size_);
    std::abort();
  }
  vkCmdPushConstants(cmd, layout_, stages_, 0, size, data);
}

}  // namespace gauss::vk
