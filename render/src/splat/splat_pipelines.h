#pragma once
// The compute pipelines of the splat renderer, created once (the specialised ones on
// first use, cached by their specialization values).
#include <cstdint>
#include <map>

#include "gauss/engine/result.h"
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
  static Expected<SplatPipelines> create(vk::Context& context, const SlotChunkLayout& chunks);

  Expected<const vk::ComputePipeline*> preprocess(const PreprocessKey& key);
  Expected<const vk::ComputePipeline*> emit(bool mesh, bool exact_cull);
  Expected<const vk::ComputePipeline*> blend(bool mesh);

  const vk::ComputePipeline& scan_visible() const noexcept { return scan_visible_; }
  const vk::ComputePipeline& scan_pairs() const noexcept { return scan_pairs_; }
  const vk::ComputePipeline& scan_hist() const noexcept { return scan_hist_; }
  const vk::ComputePipeline& compact() const noexcept { return compact_; }
  const vk::ComputePipeline& radix_count() const noexcept { return radix_count_; }
  const vk::ComputePipeline& radix_scatter() const noexcept { return radix_scatter_; }
  const vk::ComputePipeline& ranges() const noexcept { return ranges_; }
  const vk::ComputePipeline& tile_depth() const noexcept { return tile_depth_; }

 private:
  vk::Context* context_{nullptr};
  SlotChunkLayout chunks_;
  std::map<PreprocessKey, vk::ComputePipeline> preprocess_;
  std::map<std::uint32_t, vk::ComputePipeline> emit_;
  std::map<std::uint32_t, vk::ComputePipeline> blend_;
  vk::ComputePipeline scan_visible_, scan_pairs_, scan_hist_, compact_, radix_count_, radix_scatter_, ranges_,
      tile_depth_;
};

}  // namespace gauss::render::splat
