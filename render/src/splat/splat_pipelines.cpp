// Compute pipelines of the splat renderer: bindings per kernel (push descriptors) and
// the specialization constants of splat_layout.h.
#include "splat_pipelines.h"

#include <algorithm>
#include <bit>
#include <string>
#include <vector>

#include "gauss/render/splat_math.h"
#include "gauss/render/vk_context.h"
#include "gauss/shaders/sort_radix_count.comp.spv.h"
#include "gauss/shaders/sort_radix_count_gpu.comp.spv.h"
#include "gauss/shaders/sort_radix_offsets_gpu.comp.spv.h"
#include "gauss/shaders/sort_radix_scatter.comp.spv.h"
#include "gauss/shaders/sort_radix_scatter_gpu.comp.spv.h"
#include "gauss/shaders/splat_blend.comp.spv.h"
#include "gauss/shaders/splat_blend_gpu.comp.spv.h"
#include "gauss/shaders/splat_compact.comp.spv.h"
#include "gauss/shaders/splat_emit.comp.spv.h"
#include "gauss/shaders/splat_preprocess.comp.spv.h"
#include "gauss/shaders/splat_ranges.comp.spv.h"
#include "gauss/shaders/splat_scan.comp.spv.h"
#include "gauss/shaders/splat_scan_gpu.comp.spv.h"
#include "gauss/shaders/splat_tile_depth.comp.spv.h"
#include "splat_layout.h"

namespace gauss::render::splat {

namespace {

using vk::DescriptorKind;
constexpr auto SB = DescriptorKind::StorageBuffer;

// The C++ and GLSL views of the splat math must agree with splat_math.h.
static_assert(gpu::SPLAT_TILE == static_cast<std::uint32_t>(kTileSize));
static_assert(gpu::SORT_BLOCK == gpu::SPLAT_WORKGROUP * gpu::SORT_ITEMS);
static_assert(gpu::SORT_BLOCK_GPU == gpu::SPLAT_WORKGROUP * gpu::SORT_ITEMS_GPU);
// The GPU scan keeps its block sums in hist, sized for the smaller radix block
// (splat_memory_plan.cpp): one sum per SORT_BLOCK_GPU values fits.
static_assert(gpu::SORT_BLOCK_GPU <= gpu::SORT_BLOCK);
static_assert(gpu::SPLAT_WORKGROUP / gpu::SPLAT_MAX_SUBGROUPS == 4, "SPLAT_MAX_SUBGROUPS: subgroups of 4");
static_assert(gpu::SORT_BINS == (1u << gpu::SORT_RADIX_BITS));
static_assert(gpu::SORT_BINS_MAX == (1u << gpu::SORT_RADIX_BITS_MAX) && gpu::SORT_BINS_MAX <= gpu::SPLAT_WORKGROUP);
static_assert(gpu::SPLAT_BLEND_THREADS * gpu::SPLAT_BLEND_PIXELS == gpu::SPLAT_TILE * gpu::SPLAT_TILE);
static_assert(gpu::SPLAT_BLEND_PIXELS * 2 == gpu::SPLAT_TILE);  // two invocations per column
static_assert(gpu::SPLAT_DILATION == static_cast<float>(kDilation));
static_assert(gpu::SPLAT_FRUSTUM_CLAMP == static_cast<float>(kFrustumClamp));
static_assert(gpu::SPLAT_NEAR_CULL == static_cast<float>(kNearCull));
// splat_preprocess.comp culls with t.z >= float(kNearCull), which equals t.z > kNearCull
// for float t.z only because float(kNearCull) lies above kNearCull.
static_assert(static_cast<double>(gpu::SPLAT_NEAR_CULL) > kNearCull);
static_assert(gpu::SPLAT_LAMBDA_FLOOR == static_cast<float>(kLambdaFloor));
static_assert(gpu::SPLAT_SIGMA_EXTENT == static_cast<float>(kSigmaExtent));
static_assert(gpu::SPLAT_ALPHA_MIN == static_cast<float>(kAlphaMin));
static_assert(gpu::SPLAT_ALPHA_MAX == static_cast<float>(kAlphaMax));
static_assert(gpu::SPLAT_T_STOP == static_cast<float>(kTransmittanceStop));
static_assert(gpu::SPLAT_HIGHLIGHT_STRENGTH == static_cast<float>(kHighlightStrength));
static_assert(gpu::SPLAT_EDIT_STRENGTH == static_cast<float>(kEditTintStrength));
static_assert(gpu::SPLAT_EDIT_TINT_FRAMES == kEditTintFrames);
static_assert(gpu::SPLAT_REMOVED_FADE_FRAMES == kRemovedFadeFrames);
static_assert(kHighlightColour[0] == 1.0 && kHighlightColour[1] == 0.8 && kHighlightColour[2] == 0.0,
              "splat_preprocess.comp hard-codes the highlight colour");
static_assert(kAddedColour[1] == 1.0 && kReplacedColour[2] == 1.0 && kRemovedColour[0] == 1.0,
              "splat_preprocess.comp hard-codes the edit tint colours");

// full_subgroups: the GPU shapes number invocations by (subgroup, lane) and give each
// subgroup a share of a block, which covers the block only when every subgroup is full
// (splat_subgroup.glsl); the device guarantees it where it can.
Expected<vk::ComputePipeline> make(vk::Context& context, const char* name, vk::SpirvCode code,
                                   std::vector<vk::DescriptorBinding> bindings,
                                   std::vector<vk::SpecConstant> spec = {}, bool full_subgroups = false) {
  auto p = vk::ComputePipeline::create(context, {.name = name,
                                                 .shader = code,
                                                 .bindings = std::move(bindings),
                                                 .push_constant_size = sizeof(gpu::GpuSplatPush),
                                                 .spec_constants = std::move(spec),
                                                 .require_full_subgroups = full_subgroups});
  if (!p) return Error{std::string("splat renderer: ") + p.message()};
  return std::move(*p);
}

std::vector<vk::DescriptorBinding> scan_bindings() {
  return {{gpu::SPLAT_BINDING_TILE_COUNT, SB}, {gpu::SPLAT_BINDING_VALS_IN, SB}, {gpu::SPLAT_BINDING_OFFSETS, SB},
          {gpu::SPLAT_BINDING_HIST, SB},       {gpu::SPLAT_BINDING_COUNTERS, SB}};
}

std::vector<vk::DescriptorBinding> scatter_bindings() {
  return {{gpu::SPLAT_BINDING_KEYS_IN, SB},  {gpu::SPLAT_BINDING_VALS_IN, SB}, {gpu::SPLAT_BINDING_KEYS_OUT, SB},
          {gpu::SPLAT_BINDING_VALS_OUT, SB}, {gpu::SPLAT_BINDING_HIST, SB},    {gpu::SPLAT_BINDING_COUNTERS, SB}};
}

// Readers of projected splats by slot bind every chunk (splat_projected.glsl).
void add_projected_chunks(std::vector<vk::DescriptorBinding>& bindings) {
  for (std::uint32_t b : {gpu::SPLAT_BINDING_PROJECTED_1, gpu::SPLAT_BINDING_PROJECTED_2, gpu::SPLAT_BINDING_PROJECTED_3})
    bindings.push_back({b, SB});
}

std::vector<vk::SpecConstant> chunk_spec(const SlotChunkLayout& chunks) {
  return {{gpu::SPLAT_SPEC_SLOT_CHUNKS, chunks.chunks},
          {gpu::SPLAT_SPEC_SLOT_CHUNK_SHIFT,
           chunks.chunks > 1 ? static_cast<std::uint32_t>(std::countr_zero(chunks.chunk_slots)) : 31u}};
}

// splat_blend.comp's ballot words: one per 32 invocations of the largest subgroup.
std::uint32_t ballot_words(const vk::Context& context) {
  return std::clamp((context.max_subgroup_size() + 31u) / 32u, 1u, 4u);
}

// The blend culls and broadcasts splats within a subgroup (compute stage).
constexpr VkSubgroupFeatureFlags kBlendSubgroupOps = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_VOTE_BIT |
                                                     VK_SUBGROUP_FEATURE_ARITHMETIC_BIT |
                                                     VK_SUBGROUP_FEATURE_BALLOT_BIT;

}  // namespace

Expected<SplatPipelines> SplatPipelines::create(vk::Context& context, const SlotChunkLayout& chunks,
                                                const SplatPassProfile& profile) {
  if (chunks.chunks == 0 || chunks.chunks > gpu::SPLAT_MAX_SLOT_CHUNKS ||
      (chunks.chunks > 1 && !std::has_single_bit(chunks.chunk_slots)))
    return Error{"splat renderer: " + std::to_string(chunks.chunks) + " slot chunks of " +
                 std::to_string(chunks.chunk_slots) + " slots (1.." + std::to_string(gpu::SPLAT_MAX_SLOT_CHUNKS) +
                 " chunks of a power of two)"};
  if ((context.subgroup_operations() & kBlendSubgroupOps) != kBlendSubgroupOps)
    return Error{"splat renderer: the device lacks compute subgroup basic, vote, arithmetic and ballot operations "
                 "(device " + context.device_name() + ")"};
  SplatPipelines p;
  p.context_ = &context;
  p.chunks_ = chunks;
  p.shapes_ = profile.shapes == SplatPassShapes::Gpu ? SplatPassShapes::Gpu : SplatPassShapes::Cpu;
  const bool g = p.shapes_ == SplatPassShapes::Gpu;
  if (g && !((profile.radix_bits == gpu::SORT_RADIX_BITS || profile.radix_bits == gpu::SORT_RADIX_BITS_MAX) &&
             profile.sort_rows >= 1 && profile.sort_rows <= gpu::SPLAT_MAX_SUBGROUPS))
    return Error{"splat renderer: radix digits of " + std::to_string(profile.radix_bits) + " bits with " +
                 std::to_string(profile.sort_rows) + " scatter rows (4 or 8 bits, 1.." +
                 std::to_string(gpu::SPLAT_MAX_SUBGROUPS) + " rows)"};
  p.radix_bits_ = g ? profile.radix_bits : gpu::SORT_RADIX_BITS;
  const vk::SpecConstant digit_spec{gpu::SORT_SPEC_RADIX_BITS, p.radix_bits_};
  struct Fixed {
    vk::ComputePipeline* out;
    const char* name;
    vk::SpirvCode code;
    std::vector<vk::DescriptorBinding> bindings;
    std::vector<vk::SpecConstant> spec;
    bool full_subgroups{false};  // a GPU-shape shader (splat_subgroup.glsl)
  };
  // The CPU scan has one step; the GPU scan's SPLAT_SPEC_SCAN_PHASE picks reduce, spine or down.
  const vk::SpirvCode scan_code = g ? vk::spirv(gauss_spv_splat_scan_gpu_comp) : vk::spirv(gauss_spv_splat_scan_comp);
  auto scan_spec = [&](std::uint32_t mode, std::uint32_t phase) -> std::vector<vk::SpecConstant> {
    if (!g) return {{gpu::SPLAT_SPEC_SCAN_MODE, mode}};
    return {{gpu::SPLAT_SPEC_SCAN_MODE, mode}, {gpu::SPLAT_SPEC_SCAN_PHASE, phase}, digit_spec};
  };
  std::vector<Fixed> fixed = {
      {&p.scan_visible_, "splat scan (visible)", scan_code, scan_bindings(),
       scan_spec(gpu::SPLAT_SCAN_VISIBLE, gpu::SPLAT_SCAN_PHASE_SPINE), g},
      {&p.scan_pairs_, "splat scan (pairs)", scan_code, scan_bindings(),
       scan_spec(gpu::SPLAT_SCAN_PAIRS, gpu::SPLAT_SCAN_PHASE_SPINE), g},
      g ? Fixed{&p.scan_hist_, "radix digit offsets", vk::spirv(gauss_spv_sort_radix_offsets_gpu_comp),
                {{gpu::SPLAT_BINDING_HIST, SB}, {gpu::SPLAT_BINDING_COUNTERS, SB}}, {digit_spec}, true}
        : Fixed{&p.scan_hist_, "splat scan (radix histogram)", scan_code, scan_bindings(),
                scan_spec(gpu::SPLAT_SCAN_HIST, gpu::SPLAT_SCAN_PHASE_SPINE), false},
      {&p.compact_, "splat compact", vk::spirv(gauss_spv_splat_compact_comp),
       {{gpu::SPLAT_BINDING_PROJECTED, SB},
        {gpu::SPLAT_BINDING_TILE_COUNT, SB},
        {gpu::SPLAT_BINDING_OFFSETS, SB},
        {gpu::SPLAT_BINDING_KEYS_OUT, SB},
        {gpu::SPLAT_BINDING_VALS_OUT, SB}},
       {}},
      {&p.radix_count_, "radix count",
       g ? vk::spirv(gauss_spv_sort_radix_count_gpu_comp) : vk::spirv(gauss_spv_sort_radix_count_comp),
       {{gpu::SPLAT_BINDING_KEYS_IN, SB}, {gpu::SPLAT_BINDING_HIST, SB}, {gpu::SPLAT_BINDING_COUNTERS, SB}},
       g ? std::vector<vk::SpecConstant>{digit_spec} : std::vector<vk::SpecConstant>{},
       g},
      {&p.radix_scatter_, "radix scatter",
       g ? vk::spirv(gauss_spv_sort_radix_scatter_gpu_comp) : vk::spirv(gauss_spv_sort_radix_scatter_comp),
       scatter_bindings(),
       g ? std::vector<vk::SpecConstant>{digit_spec, {gpu::SORT_SPEC_ROWS, profile.sort_rows}}
         : std::vector<vk::SpecConstant>{},
       g},
      {&p.ranges_, "splat tile ranges", vk::spirv(gauss_spv_splat_ranges_comp),
       {{gpu::SPLAT_BINDING_VIEW, DescriptorKind::UniformBuffer},
        {gpu::SPLAT_BINDING_KEYS_IN, SB},
        {gpu::SPLAT_BINDING_RANGES, SB},
        {gpu::SPLAT_BINDING_COUNTERS, SB}},
       {}},
      {&p.tile_depth_, "splat tile max depth", vk::spirv(gauss_spv_splat_tile_depth_comp),
       {{gpu::SPLAT_BINDING_VIEW, DescriptorKind::UniformBuffer},
        {gpu::SPLAT_BINDING_MESH_DEPTH, DescriptorKind::SampledImage},
        {gpu::SPLAT_BINDING_TILE_DEPTH, SB}},
       {}},
  };
  if (g) {
    fixed.push_back({&p.scan_visible_reduce_, "splat scan (visible, reduce)", scan_code, scan_bindings(),
                     scan_spec(gpu::SPLAT_SCAN_VISIBLE, gpu::SPLAT_SCAN_PHASE_REDUCE), true});
    fixed.push_back({&p.scan_visible_down_, "splat scan (visible, down)", scan_code, scan_bindings(),
                     scan_spec(gpu::SPLAT_SCAN_VISIBLE, gpu::SPLAT_SCAN_PHASE_DOWN), true});
    fixed.push_back({&p.scan_pairs_reduce_, "splat scan (pairs, reduce)", scan_code, scan_bindings(),
                     scan_spec(gpu::SPLAT_SCAN_PAIRS, gpu::SPLAT_SCAN_PHASE_REDUCE), true});
    fixed.push_back({&p.scan_pairs_down_, "splat scan (pairs, down)", scan_code, scan_bindings(),
                     scan_spec(gpu::SPLAT_SCAN_PAIRS, gpu::SPLAT_SCAN_PHASE_DOWN), true});
    fixed.push_back({&p.radix_scatter_fused_, "radix scatter (own offsets)", vk::spirv(gauss_spv_sort_radix_scatter_gpu_comp),
                     scatter_bindings(),
                     {digit_spec, {gpu::SORT_SPEC_ROWS, profile.sort_rows}, {gpu::SORT_SPEC_FUSED_OFFSETS, 1}},
                     true});
  }
  for (const Fixed& f : fixed) {
    auto pipe = make(context, f.name, f.code, f.bindings, f.spec, f.full_subgroups);
    if (!pipe) return pipe.error();
    *f.out = std::move(*pipe);
  }
  return p;
}

Expected<const vk::ComputePipeline*> SplatPipelines::preprocess(const PreprocessKey& key) {
  if (auto it = preprocess_.find(key); it != preprocess_.end()) return &it->second;
  auto pipe = make(*context_, "splat preprocess", vk::spirv(gauss_spv_splat_preprocess_comp),
                   {{gpu::SPLAT_BINDING_VIEW, DescriptorKind::UniformBuffer},
                    {gpu::SPLAT_BINDING_CORE, SB},
                    {gpu::SPLAT_BINDING_SH, SB},
                    {gpu::SPLAT_BINDING_SH_HIGH, SB},
                    {gpu::SPLAT_BINDING_EDIT, SB},
                    {gpu::SPLAT_BINDING_HIGHLIGHT, SB},
                    {gpu::SPLAT_BINDING_PROJECTED, SB},
                    {gpu::SPLAT_BINDING_TILE_COUNT, SB},
                    {gpu::SPLAT_BINDING_TILE_DEPTH, SB}},
                   {{gpu::SPLAT_SPEC_SH_DEGREE, key.sh_degree},
                    {gpu::SPLAT_SPEC_TINT, key.tint ? 1u : 0u},
                    {gpu::SPLAT_SPEC_MESH, key.mesh ? 1u : 0u},
                    {gpu::SPLAT_SPEC_SH_STRIDE, key.sh_stride},
                    {gpu::SPLAT_SPEC_EXACT_CULL, key.exact_cull ? 1u : 0u}});
  if (!pipe) return pipe.error();
  return &preprocess_.emplace(key, std::move(*pipe)).first->second;
}

Expected<const vk::ComputePipeline*> SplatPipelines::emit(bool mesh, bool exact_cull) {
  const std::uint32_t key = (mesh ? 1u : 0u) | (exact_cull ? 2u : 0u);
  if (auto it = emit_.find(key); it != emit_.end()) return &it->second;
  std::vector<vk::DescriptorBinding> bindings = {{gpu::SPLAT_BINDING_VIEW, DescriptorKind::UniformBuffer},
                                                 {gpu::SPLAT_BINDING_PROJECTED, SB},
                                                 {gpu::SPLAT_BINDING_TILE_COUNT, SB},
                                                 {gpu::SPLAT_BINDING_OFFSETS, SB},
                                                 {gpu::SPLAT_BINDING_VALS_IN, SB},
                                                 {gpu::SPLAT_BINDING_KEYS_OUT, SB},
                                                 {gpu::SPLAT_BINDING_VALS_OUT, SB},
                                                 {gpu::SPLAT_BINDING_COUNTERS, SB},
                                                 {gpu::SPLAT_BINDING_TILE_DEPTH, SB}};
  add_projected_chunks(bindings);
  std::vector<vk::SpecConstant> spec = chunk_spec(chunks_);
  spec.push_back({gpu::SPLAT_SPEC_MESH, mesh ? 1u : 0u});
  spec.push_back({gpu::SPLAT_SPEC_EXACT_CULL, exact_cull ? 1u : 0u});
  auto pipe = make(*context_, "splat emit", vk::spirv(gauss_spv_splat_emit_comp), std::move(bindings), std::move(spec));
  if (!pipe) return pipe.error();
  return &emit_.emplace(key, std::move(*pipe)).first->second;
}

Expected<const vk::ComputePipeline*> SplatPipelines::blend(bool mesh) {
  const std::uint32_t key = mesh ? 1u : 0u;
  if (auto it = blend_.find(key); it != blend_.end()) return &it->second;
  std::vector<vk::DescriptorBinding> bindings = {{gpu::SPLAT_BINDING_VIEW, DescriptorKind::UniformBuffer},
                                                 {gpu::SPLAT_BINDING_PROJECTED, SB},
                                                 {gpu::SPLAT_BINDING_VALS_IN, SB},
                                                 {gpu::SPLAT_BINDING_RANGES, SB},
                                                 {gpu::SPLAT_BINDING_OUTPUT, SB},
                                                 {gpu::SPLAT_BINDING_MESH_COLOUR, DescriptorKind::StorageImage},
                                                 {gpu::SPLAT_BINDING_MESH_DEPTH, DescriptorKind::SampledImage}};
  add_projected_chunks(bindings);
  std::vector<vk::SpecConstant> spec = chunk_spec(chunks_);
  spec.push_back({gpu::SPLAT_SPEC_MESH, key});
  // CPU shape: a subgroup culls and broadcasts (ballot words); GPU shape: 256 pixels share
  // shared-memory batches (splat_blend_gpu.comp).
  const bool g = shapes_ == SplatPassShapes::Gpu;
  if (!g) spec.push_back({gpu::SPLAT_SPEC_BALLOT_WORDS, ballot_words(*context_)});
  auto pipe = make(*context_, g ? "splat blend (batched)" : "splat blend",
                   g ? vk::spirv(gauss_spv_splat_blend_gpu_comp) : vk::spirv(gauss_spv_splat_blend_comp),
                   std::move(bindings), std::move(spec));
  if (!pipe) return pipe.error();
  return &blend_.emplace(key, std::move(*pipe)).first->second;
}

}  // namespace gauss::render::splat
