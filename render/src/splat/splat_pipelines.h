#pragma once
// The compute pipelines of the splat renderer, created once (the specialised ones on
// first use, cached by their specialization values).
#include <cstdint>
#include <map>

#include "gauss/engine/result.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_pipeline.h"

namespace gauss::vk {
class Context;
}

namespace gauss::render::splat {

struct PreprocessKey {
  std::uint32_t sh_degree{0};
  std::uint32_t sh_stride{0};
  bool tint{false};
  bool mesh{false};
  bool exact_cull{true};
  auto operator<=>(const PreprocessKey&) const = default;
};

// How the projected splats are split over bindings (splat_memory_plan.h): emit and blend
// are specialised for it.
struct SlotChunkLayout {
  std::uint32_t chunks{1};
  std::uint32_t chunk_slots{0};  // a power of two when chunks > 1
};

class SplatPipelines {
 public:
  // `profile` (resolved by choose_pass_shapes): which shaders the scans and the radix
  // passes take, and the GPU radix passes' digit width. The other passes have one shape.
  static Expected<SplatPipelines> create(vk::Context& context, const SlotChunkLayout& chunks,
                                         const SplatPassProfile& profile);

  SplatPassShapes shapes() const noexcept { return shapes_; }
  // Key bits per radix pass (4 or 8; always 4 with the CPU shapes).
  std::uint32_t radix_bits() const noexcept { return radix_bits_; }

  Expected<const vk::ComputePipeline*> preprocess(const PreprocessKey& key);
  Expected<const vk::ComputePipeline*> emit(bool mesh, bool exact_cull);
  Expected<const vk::ComputePipeline*> blend(bool mesh);

  // Cpu: the whole scan in one workgroup. Gpu: the spine (one workgroup) between the
  // reduce and down dispatches below.
  const vk::ComputePipeline& scan_visible() const noexcept { return scan_visible_; }
  const vk::ComputePipeline& scan_pairs() const noexcept { return scan_pairs_; }
  // Cpu: the whole histogram scanned in one workgroup (absolute offsets). Gpu: one
  // workgroup per digit (sort_radix_offsets_gpu.comp; binds only hist and counters).
  const vk::ComputePipeline& scan_hist() const noexcept { return scan_hist_; }
  // Gpu only: block sums and the per-block rescans of the visible and pair scans.
  const vk::ComputePipeline& scan_visible_reduce() const noexcept { return scan_visible_reduce_; }
  const vk::ComputePipeline& scan_visible_down() const noexcept { return scan_visible_down_; }
  const vk::ComputePipeline& scan_pairs_reduce() const noexcept { return scan_pairs_reduce_; }
  const vk::ComputePipeline& scan_pairs_down() const noexcept { return scan_pairs_down_; }
  const vk::ComputePipeline& compact() const noexcept { return compact_; }
  const vk::ComputePipeline& radix_count() const noexcept { return radix_count_; }
  const vk::ComputePipeline& radix_scatter() const noexcept { return radix_scatter_; }
  // Gpu only: the scatter that sums its block counts itself (no offsets pass before it),
  // for sorts of at most SORT_FUSED_OFFSETS_MAX_BLOCKS blocks.
  const vk::ComputePipeline& radix_scatter_fused() const noexcept { return radix_scatter_fused_; }
  const vk::ComputePipeline& ranges() const noexcept { return ranges_; }
  const vk::ComputePipeline& tile_depth() const noexcept { return tile_depth_; }

 private:
  vk::Context* context_{nullptr};
  SlotChunkLayout chunks_;
  SplatPassShapes shapes_{SplatPassShapes::Cpu};
  std::uint32_t radix_bits_{4};
  std::map<PreprocessKey, vk::ComputePipeline> preprocess_;
  std::map<std::uint32_t, vk::ComputePipeline> emit_;
  std::map<std::uint32_t, vk::ComputePipeline> blend_;
  vk::ComputePipeline scan_visible_, scan_pairs_, scan_hist_, compact_, radix_count_, radix_scatter_, ranges_,
      tile_depth_;
  vk::ComputePipeline scan_visible_reduce_, scan_visible_down_, scan_pairs_reduce_, scan_pairs_down_,
      radix_scatter_fused_;
};

}  // namespace gauss::render::splat
