#pragma once
// GpuFrameStatsCollector: the GPU side of frames in flight. A frame's pass timings and
// counters exist only once its fence has signalled, a few frames after it was recorded;
// this keeps the submitted serials in order and collects each frame's statistics from the
// renderer as soon as it has finished (never waiting for one that has not).
#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_frame_ring.h"

namespace gauss::client {

struct GpuFrameStats {
  std::uint64_t frame_index{0};
  std::uint64_t serial{0};
  std::uint32_t views{0};
  std::array<render::SplatFrameStats, 2> view{};
  double total_ms{0.0};  // GPU time of all views
};

class GpuFrameStatsCollector {
 public:
  void submitted(std::uint64_t serial, std::uint64_t frame_index, std::uint32_t views) {
    in_flight_.push_back({serial, frame_index, views});
  }
  // Moves every finished frame's statistics to the done list (non-blocking).
  void collect(render::SplatRenderer& renderer) {
    const std::uint64_t done = renderer.frames().poll();
    while (!in_flight_.empty() && in_flight_.front().serial <= done) {
      const InFlight f = in_flight_.front();
      in_flight_.pop_front();
      auto s = renderer.frame_stats(f.serial);
      if (!s) continue;  // its frame slot was reused: only when frames were not collected in time
      GpuFrameStats g;
      g.frame_index = f.frame_index;
      g.serial = f.serial;
      g.views = f.views;
      g.view = *s;
      for (std::uint32_t v = 0; v < f.views; ++v) g.total_ms += (*s)[v].gpu.total_ms;
      last_total_ms_ = g.total_ms;
      done_.push_back(g);
    }
  }
  // The statistics collected since the last call, oldest first.
  std::vector<GpuFrameStats> take(render::SplatRenderer& renderer) {
    collect(renderer);
    std::vector<GpuFrameStats> out;
    out.swap(done_);
    return out;
  }
  double last_total_ms() const noexcept { return last_total_ms_; }
  void clear() noexcept { in_flight_.clear(); }

 private:
  struct InFlight {
    std::uint64_t serial;
    std::uint64_t frame_index;
    std::uint32_t views;
  };
  std::deque<InFlight> in_flight_;
  std::vector<GpuFrameStats> done_;
  double last_total_ms_{0.0};
};

}  // namespace gauss::client
