// ComputePipeline and GraphicsPipeline creation from embedded SPIR-V.
#include <string>
#include <vector>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_pipeline.h"

namespace gauss::vk {
namespace {

constexpr std::uint32_t kSpirvMagic = 0x07230203u;

// Owns a shader module for the duration of pipeline creation only.
struct ShaderModule {
  VkDevice device{VK_NULL_HANDLE};
  VkShaderModule module{VK_NULL_HANDLE};
  ShaderModule() = default;
  ShaderModule(const ShaderModule&) = delete;
  ShaderModule& operator=(const ShaderModule&) = delete;
  ~ShaderModule() {
    if (module) vkDestroyShaderModule(device, module, nullptr);
  }
};

Status create_module(Context& context, const SpirvCode& code, const std::string& what, ShaderModule& out) {
  if (code.words == nullptr || code.size_bytes < 20 || code.size_bytes % 4 != 0) {
    return Error{what + ": SPIR-V of " + std::to_string(code.size_bytes) +
                 " bytes is empty or not a whole number of 32-bit words"};
  }
  if (code.words[0] != kSpirvMagic) return Error{what + ": not SPIR-V (bad magic number)"};
  VkShaderModuleCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  ci.codeSize = code.size_bytes;
  ci.pCode = code.words;
  out.device = context.device();
  GAUSS_VK_TRY(vkCreateShaderModule(context.device(), &ci, nullptr, &out.module));
  return Ok{};
}

// Specialization data: every constant is 32 bits, laid out in declaration order.
struct Specialization {
  std::vector<VkSpecializationMapEntry> entries;
  std::vector<std::uint32_t> data;
  VkSpecializationInfo info{};

  Specialization(const Specialization&) = delete;
  Specialization& operator=(const Specialization&) = delete;
  explicit Specialization(const std::vector<SpecConstant>& constants) {
    for (std::size_t i = 0; i < constants.size(); ++i) {
      entries.push_back({constants[i].id, static_cast<std::uint32_t>(i * sizeof(std::uint32_t)), sizeof(std::uint32_t)});
      data.push_back(constants[i].value);
    }
    info.mapEntryCount = static_cast<std::uint32_t>(entries.size());
    info.pMapEntries = entries.data();
    info.dataSize = data.size() * sizeof(std::uint32_t);
    info.pData = data.data();
  }
  const VkSpecializationInfo* get() const { return entries.empty() ? nullptr : &info; }
};

Status check_spec_ids(const std::vector<SpecConstant>& constants, const std::string& what) {
  for (std::size_t i = 0; i < constants.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (constants[i].id == constants[j].id) {
        return Error{what + ": specialization constant " + std::to_string(constants[i].id) + " given twice"};
      }
    }
  }
  return Ok{};
}

}  // namespace

Expected<ComputePipeline> ComputePipeline::create(Context& context, const ComputePipelineCreateInfo& info) {
  const std::string what = "compute pipeline '" + info.name + "'";
  ComputePipeline p;
  p.bind_point_ = VK_PIPELINE_BIND_POINT_COMPUTE;
  if (auto st = p.create_layout(context, info.name, info.bindings, info.push_constant_size, VK_SHADER_STAGE_COMPUTE_BIT);
      !st) {
    return st.error();
  }
  if (auto st = check_spec_ids(info.spec_constants, what); !st) return st.error();
  ShaderModule module;
  if (auto st = create_module(context, info.shader, what, module); !st) return st.error();
  const Specialization spec(info.spec_constants);
  VkComputePipelineCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  if (info.require_full_subgroups && context.enabled_features13().computeFullSubgroups)
    ci.stage.flags |= VK_PIPELINE_SHADER_STAGE_CREATE_REQUIRE_FULL_SUBGROUPS_BIT;
  ci.stage.module = module.module;
  ci.stage.pName = info.entry_point.c_str();
  ci.stage.pSpecializationInfo = spec.get();
  ci.layout = p.layout_;
  GAUSS_VK_TRY(vkCreateComputePipelines(context.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &p.pipeline_));
  context.set_debug_name(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<std::uint64_t>(p.pipeline_), info.name.c_str());
  return p;
}

Expected<GraphicsPipeline> GraphicsPipeline::create(Context& context, const GraphicsPipelineCreateInfo& info) {
  const std::string what = "graphics pipeline '" + info.name + "'";
  GraphicsPipeline p;
  p.bind_point_ = VK_PIPELINE_BIND_POINT_GRAPHICS;
  if (auto st = p.create_layout(context, info.name, info.bindings, info.push_constant_size,
                                VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
      !st) {
    return st.error();
  }
  if (auto st = check_spec_ids(info.spec_constants, what); !st) return st.error();
  if (info.vertex_stride == 0 && !info.attributes.empty()) {
    return Error{what + ": vertex attributes given with vertex_stride 0"};
  }
  for (const VertexAttribute& a : info.attributes) {
    if (a.offset >= info.vertex_stride) {
      return Error{what + ": attribute at location " + std::to_string(a.location) + " starts at offset " +
                   std::to_string(a.offset) + ", outside the " + std::to_string(info.vertex_stride) + "-byte vertex"};
    }
  }
  ShaderModule vs;
  ShaderModule fs;
  if (auto st = create_module(context, info.vertex_shader, what + " vertex shader", vs); !st) return st.error();
  if (auto st = create_module(context, info.fragment_shader, what + " fragment shader", fs); !st) return st.error();
  const Specialization spec(info.spec_constants);

  VkPipelineShaderStageCreateInfo stages[2]{};
  stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vs.module;
  stages[0].pName = "main";
  stages[0].pSpecializationInfo = spec.get();
  stages[1] = stages[0];
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = fs.module;

  VkVertexInputBindingDescription vb{0, info.vertex_stride, VK_VERTEX_INPUT_RATE_VERTEX};
  std::vector<VkVertexInputAttributeDescription> attrs;
  for (const VertexAttribute& a : info.attributes) attrs.push_back({a.location, 0, a.format, a.offset});
  VkPipelineVertexInputStateCreateInfo vi{};
  vi.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  if (info.vertex_stride > 0) {
    vi.vertexBindingDescriptionCount = 1;
    vi.pVertexBindingDescriptions = &vb;
    vi.vertexAttributeDescriptionCount = static_cast<std::uint32_t>(attrs.size());
    vi.pVertexAttributeDescriptions = attrs.data();
  }
  VkPipelineInputAssemblyStateCreateInfo ia{};
  ia.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
  ia.topology = info.topology;
  VkPipelineViewportStateCreateInfo vp{};
  vp.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{};
  rs.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = info.cull_mode;
  rs.frontFace = info.front_face;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{};
  ms.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{};
  ds.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  ds.depthTestEnable = info.depth_test ? VK_TRUE : VK_FALSE;
  ds.depthWriteEnable = info.depth_write ? VK_TRUE : VK_FALSE;
  ds.depthCompareOp = info.depth_compare;
  VkPipelineColorBlendAttachmentState blend{};
  blend.colorWriteMask =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  if (info.alpha_blend) {
    blend.blendEnable = VK_TRUE;
    blend.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
    blend.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    blend.colorBlendOp = VK_BLEND_OP_ADD;
    blend.srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
    blend.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    blend.alphaBlendOp = VK_BLEND_OP_ADD;
  }
  VkPipelineColorBlendStateCreateInfo cb{};
  cb.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  cb.attachmentCount = 1;
  cb.pAttachments = &blend;
  const VkDynamicState dynamic[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dyn{};
  dyn.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dyn.dynamicStateCount = 2;
  dyn.pDynamicStates = dynamic;
  VkPipelineRenderingCreateInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &info.color_format;
  rendering.depthAttachmentFormat = info.depth_format;

  VkGraphicsPipelineCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  ci.pNext = &rendering;
  ci.stageCount = 2;
  ci.pStages = stages;
  ci.pVertexInputState = &vi;
  ci.pInputAssemblyState = &ia;
  ci.pViewportState = &vp;
  ci.pRasterizationState = &rs;
  ci.pMultisampleState = &ms;
  ci.pDepthStencilState = &ds;
  ci.pColorBlendState = &cb;
  ci.pDynamicState = &dyn;
  ci.layout = p.layout_;
  GAUSS_VK_TRY(vkCreateGraphicsPipelines(context.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &p.pipeline_));
  context.set_debug_name(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<std::uint64_t>(p.pipeline_), info.name.c_str());
  return p;
}

}  // namespace gauss::vk
