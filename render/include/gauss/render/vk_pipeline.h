#pragma once
// Compute and graphics pipelines built from embedded SPIR-V, with one descriptor set
// (set 0) written through VK_KHR_push_descriptor at bind time: no pools, no set
// lifetimes to manage. Push constants and specialization constants are supported.
//
// SPIR-V comes from the build: shaders/X.comp becomes <gauss/shaders/X.comp.spv.h>
// holding `const uint32_t gauss_spv_X_comp[]`; pass it as spirv(gauss_spv_X_comp).
//
//   auto pipe = ComputePipeline::create(ctx, {.name = "pattern",
//       .shader = spirv(gauss_spv_test_pattern_comp),
//       .bindings = {{0, DescriptorKind::StorageImage}},
//       .push_constant_size = sizeof(Push)});
//   ctx.submit_and_wait([&](VkCommandBuffer cmd) {
//     pipe->bind(cmd, {{0, &target.color()}});   // checked, returns Status
//     pipe->push_constants(cmd, push);
//     vkCmdDispatch(cmd, gx, gy, 1);
//   });
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;
class Buffer;
class Image;

// Embedded SPIR-V words.
struct SpirvCode {
  const std::uint32_t* words{nullptr};
  std::size_t size_bytes{0};
};
template <std::size_t N>
constexpr SpirvCode spirv(const std::uint32_t (&words)[N]) noexcept {
  return SpirvCode{words, N * sizeof(std::uint32_t)};
}

enum class DescriptorKind {
  StorageBuffer,  // GLSL: layout(std430, binding = n) buffer
  UniformBuffer,  // GLSL: layout(std140, binding = n) uniform
  StorageImage,   // GLSL: layout(rgba8, binding = n) uniform image2D (GENERAL layout)
  SampledImage,   // GLSL: uniform sampler2D, with Context::nearest_sampler()
                  //       (SHADER_READ_ONLY_OPTIMAL; or DEPTH_READ_ONLY for depth)
};

struct DescriptorBinding {
  std::uint32_t binding{0};
  DescriptorKind kind{DescriptorKind::StorageBuffer};
};

// A 32-bit specialization constant (uint, int, float bits or VkBool32).
struct SpecConstant {
  std::uint32_t id{0};
  std::uint32_t value{0};
};

// What one binding points at when a pipeline is bound. A buffer binding covers
// [offset, offset + range); range 0 means "to the end of the buffer". An image binding
// uses the image's current tracked layout, which must suit the kind (checked).
struct Resource {
  std::uint32_t binding{0};
  const Buffer* buffer{nullptr};
  const Image* image{nullptr};
  VkDeviceSize offset{0};
  VkDeviceSize range{0};

  Resource(std::uint32_t b, const Buffer* buf, VkDeviceSize off = 0, VkDeviceSize rng = 0)
      : binding(b), buffer(buf), offset(off), range(rng) {}
  Resource(std::uint32_t b, const Image* img) : binding(b), image(img) {}
};

// Shared by both pipeline kinds: the descriptor set layout (push), pipeline layout,
// and the checked push-descriptor write.
class PipelineBase {
 public:
  PipelineBase() = default;
  ~PipelineBase();
  PipelineBase(PipelineBase&& other) noexcept;
  PipelineBase& operator=(PipelineBase&& other) noexcept;
  PipelineBase(const PipelineBase&) = delete;
  PipelineBase& operator=(const PipelineBase&) = delete;

  bool valid() const noexcept { return pipeline_ != VK_NULL_HANDLE; }
  VkPipeline handle() const noexcept { return pipeline_; }
  VkPipelineLayout layout() const noexcept { return layout_; }
  const std::string& name() const noexcept { return name_; }

  // vkCmdBindPipeline + vkCmdPushDescriptorSetKHR for every declared binding.
  // Checked before anything is recorded (nothing is recorded on error): every declared
  // binding given exactly once, no undeclared binding, buffer vs image matches the
  // kind, buffer range inside the buffer, storage range <= maxStorageBufferRange,
  // offset aligned to min{Storage,Uniform}BufferOffsetAlignment, image layout suits
  // the kind. Errors name the pipeline, binding and the resource.
  Status bind(VkCommandBuffer cmd, std::span<const Resource> resources) const;
  Status bind(VkCommandBuffer cmd, std::initializer_list<Resource> resources) const {
    return bind(cmd, std::span<const Resource>(resources.begin(), resources.size()));
  }

  // vkCmdPushConstants at offset 0. `size` must not exceed the declared size (fatal
  // otherwise: a programming error, not an input error).
  void push_constants(VkCommandBuffer cmd, const void* data, std::uint32_t size) const;
  template <class T>
  void push_constants(VkCommandBuffer cmd, const T& value) const {
    push_constants(cmd, &value, static_cast<std::uint32_t>(sizeof(T)));
  }

 protected:
  // Creates set layout + pipeline layout; `stages` are the stages that see them.
  Status create_layout(Context& context, const std::string& name, std::span<const DescriptorBinding> bindings,
                       std::uint32_t push_constant_size, VkShaderStageFlags stages);
  void destroy() noexcept;

  Context* context_{nullptr};
  std::string name_;
  std::vector<DescriptorBinding> bindings_;
  std::uint32_t push_constant_size_{0};
  VkShaderStageFlags stages_{0};
  VkPipelineBindPoint bind_point_{VK_PIPELINE_BIND_POINT_COMPUTE};
  VkDescriptorSetLayout set_layout_{VK_NULL_HANDLE};
  VkPipelineLayout layout_{VK_NULL_HANDLE};
  VkPipeline pipeline_{VK_NULL_HANDLE};
};

struct ComputePipelineCreateInfo {
  std::string name{"compute"};
  SpirvCode shader{};
  std::string entry_point{"main"};
  std::vector<DescriptorBinding> bindings{};
  std::uint32_t push_constant_size{0};  // bytes; <= maxPushConstantsSize (128 on lavapipe)
  std::vector<SpecConstant> spec_constants{};
  // Every subgroup of a workgroup full (VK_PIPELINE_SHADER_STAGE_CREATE_REQUIRE_FULL_SUBGROUPS_BIT)
  // where the device has computeFullSubgroups (core in Vulkan 1.3); ignored elsewhere. The
  // workgroup's x size must then be a multiple of the device's largest subgroup.
  bool require_full_subgroups{false};
};

class ComputePipeline : public PipelineBase {
 public:
  // Errors: empty / misaligned SPIR-V, push constants over the device limit,
  // duplicate bindings, vkCreate* failures (named).
  static Expected<ComputePipeline> create(Context& context, const ComputePipelineCreateInfo& info);
};

struct VertexAttribute {
  std::uint32_t location{0};
  VkFormat format{VK_FORMAT_R32G32B32_SFLOAT};
  std::uint32_t offset{0};
};

struct GraphicsPipelineCreateInfo {
  std::string name{"graphics"};
  SpirvCode vertex_shader{};
  SpirvCode fragment_shader{};
  // One interleaved vertex buffer (binding 0) with this stride; stride 0 = no vertex
  // input (e.g. vertices generated from gl_VertexIndex).
  std::uint32_t vertex_stride{0};
  std::vector<VertexAttribute> attributes{};
  VkPrimitiveTopology topology{VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST};
  VkCullModeFlags cull_mode{VK_CULL_MODE_NONE};
  VkFrontFace front_face{VK_FRONT_FACE_COUNTER_CLOCKWISE};
  bool depth_test{true};
  bool depth_write{true};
  VkCompareOp depth_compare{VK_COMPARE_OP_LESS_OR_EQUAL};
  bool alpha_blend{false};  // premultiplied-style "src*a + dst*(1-a)" when on
  // Attachment formats (dynamic rendering); default = OffscreenTarget's.
  VkFormat color_format{VK_FORMAT_R8G8B8A8_UNORM};
  VkFormat depth_format{VK_FORMAT_D32_SFLOAT};
  // Descriptor bindings and push constants are visible to both stages.
  std::vector<DescriptorBinding> bindings{};
  std::uint32_t push_constant_size{0};
  // Applied to both stages (ids not used by a stage are ignored by Vulkan).
  std::vector<SpecConstant> spec_constants{};
};

// Viewport and scissor are dynamic state: OffscreenTarget::begin_rendering sets them.
class GraphicsPipeline : public PipelineBase {
 public:
  static Expected<GraphicsPipeline> create(Context& context, const GraphicsPipelineCreateInfo& info);
};

}  // namespace gauss::vk
