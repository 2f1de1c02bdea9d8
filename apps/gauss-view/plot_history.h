#pragma once
// PlotHistory: the last kPlotFrames values of one figure, laid out as ImGui::PlotLines
// wants a scrolling graph (a ring: values() from offset() on, wrapping).
#include <algorithm>
#include <array>
#include <cstddef>

namespace gauss::view {

// About 4 s at 60 Hz; on lavapipe (10-50 ms frames) 5-12 s.
inline constexpr std::size_t kPlotFrames = 240;

class PlotHistory {
 public:
  void push(double v) {
    values_[next_] = static_cast<float>(v);
    next_ = (next_ + 1) % kPlotFrames;
    count_ = std::min(count_ + 1, kPlotFrames);
    last_ = static_cast<float>(v);
  }
  const float* values() const noexcept { return values_.data(); }
  // Number of values to plot and the index of the oldest (PlotLines' values_offset).
  int count() const noexcept { return static_cast<int>(count_); }
  int offset() const noexcept { return count_ < kPlotFrames ? 0 : static_cast<int>(next_); }
  float last() const noexcept { return last_; }
  float max() const noexcept {
    float m = 0.0f;
    for (std::size_t i = 0; i < count_; ++i) m = std::max(m, values_[i]);
    return m;
  }

 private:
  std::array<float, kPlotFrames> values_{};
  std::size_t next_{0};
  std::size_t count_{0};
  float last_{0.0f};
};

}  // namespace gauss::view
