#pragma once
// GPU timestamps: a query pool of `count` slots. Record reset() once per use before
// the first write(), write(i) at the points to time, then read after the submission
// has completed. Ticks are converted to nanoseconds with
// VkPhysicalDeviceLimits::timestampPeriod and masked to timestampValidBits.
#include <cstdint>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;

class TimestampQueries {
 public:
  // Errors: count 0, a queue without timestamp support, vkCreateQueryPool failure.
  static Expected<TimestampQueries> create(Context& context, std::uint32_t count);

  TimestampQueries() = default;
  ~TimestampQueries();
  TimestampQueries(TimestampQueries&& other) noexcept;
  TimestampQueries& operator=(TimestampQueries&& other) noexcept;
  TimestampQueries(const TimestampQueries&) = delete;
  TimestampQueries& operator=(const TimestampQueries&) = delete;

  std::uint32_t count() const noexcept { return count_; }
  VkQueryPool handle() const noexcept { return pool_; }

  // vkCmdResetQueryPool over all slots (must be outside a render pass).
  void reset(VkCommandBuffer cmd) const;
  // vkCmdWriteTimestamp2 at `stage` (default: after all previous work completed).
  // An index >= count() is fatal (programming error).
  void write(VkCommandBuffer cmd, std::uint32_t index,
             VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT) const;

  // Raw tick values of all slots (waits for availability). Errors: a slot never
  // written since reset() (VK_NOT_READY would hang, so availability is checked).
  Expected<std::vector<std::uint64_t>> read_ticks() const;
  // Nanoseconds between slots `begin` and `end` (end >= begin expected; an end tick
  // below the begin tick is an error, not a wrapped huge number).
  Expected<double> elapsed_ns(std::uint32_t begin, std::uint32_t end) const;

 private:
  void destroy() noexcept;

  Context* context_{nullptr};
  VkQueryPool pool_{VK_NULL_HANDLE};
  std::uint32_t count_{0};
};

}  // namespace gauss::vk
