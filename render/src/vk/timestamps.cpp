// Timestamp query pool. Reads use WITH_AVAILABILITY (never WAIT): a slot that was not
// written since reset is reported as an error instead of blocking forever.
#include "gauss/render/vk_timestamps.h"

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"

namespace gauss::vk {

Expected<TimestampQueries> TimestampQueries::create(Context& context, std::uint32_t count) {
  if (count == 0) return Error{"TimestampQueries: count 0"};
  if (context.timestamp_valid_bits() == 0) {
    return Error{"TimestampQueries: the queue of device '" + context.device_name() + "' has no timestamps"};
  }
  TimestampQueries q;
  q.context_ = &context;
  q.count_ = count;
  VkQueryPoolCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
  ci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  ci.queryCount = count;
  GAUSS_VK_TRY(vkCreateQueryPool(context.device(), &ci, nullptr, &q.pool_));
  return q;
}

TimestampQueries::~TimestampQueries() { destroy(); }

TimestampQueries::TimestampQueries(TimestampQueries&& other) noexcept
    : context_(std::exchange(other.context_, nullptr)),
      pool_(std::exchange(other.pool_, VK_NULL_HANDLE)),
      count_(std::exchange(other.count_, 0)) {}

TimestampQueries& TimestampQueries::operator=(TimestampQueries&& other) noexcept {
  if (this != &other) {
    destroy();
    context_ = std::exchange(other.context_, nullptr);
    pool_ = std::exchange(other.pool_, VK_NULL_HANDLE);
    count_ = std::exchange(other.count_, 0);
  }
  return *this;
}

void TimestampQueries::destroy() noexcept {
  if (context_ == nullptr) return;
  (void)vkDeviceWaitIdle(context_->device());
  if (pool_) vkDestroyQueryPool(context_->device(), pool_, nullptr);
  pool_ = VK_NULL_HANDLE;
  context_ = nullptr;
}

void TimestampQueries::reset(VkCommandBuffer cmd) const { vkCmdResetQueryPool(cmd, pool_, 0, count_); }

void TimestampQueries::write(VkCommandBuffer cmd, std::uint32_t index, VkPipelineStageFlags2 stage) const {
  if (index >= count_) {
    std::fprintf(stderr, "TimestampQueries::write: index %u >= count %u\n", index, count_);
    std::abort();
  }
  vkCmdWriteTimestamp2(cmd, stage, pool_, index);
}

Expected<std::vector<std::uint64_t>> TimestampQueries::read_ticks() const {
  if (context_ == nullptr) return Error{"TimestampQueries: empty query pool"};
  std::vector<std::uint64_t> raw(2 * static_cast<std::size_t>(count_));
  const VkResult r = vkGetQueryPoolResults(context_->device(), pool_, 0, count_, raw.size() * sizeof(std::uint64_t),
                                           raw.data(), 2 * sizeof(std::uint64_t),
                                           VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
  if (r != VK_SUCCESS && r != VK_NOT_READY) {
    return result_error(r, "vkGetQueryPoolResults", __FILE__, __LINE__);
  }
  const std::uint32_t bits = context_->timestamp_valid_bits();
  const std::uint64_t mask = bits >= 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << bits) - 1);
  std::vector<std::uint64_t> out(count_);
  for (std::uint32_t i = 0; i < count_; ++i) {
    if (raw[2 * i + 1] == 0) {
      return Error{"timestamp " + std::to_string(i) + " of " + std::to_string(count_) +
                   " is not available: not written since reset(), or its submission has not completed"};
    }
    out[i] = raw[2 * i] & mask;
  }
  return out;
}

Expected<double> TimestampQueries::elapsed_ns(std::uint32_t begin, std::uint32_t end) const {
  if (begin >= count_ || end >= count_) {
    return Error{"timestamp slots " + std::to_string(begin) + ".." + std::to_string(end) + " outside 0.." +
                 std::to_string(count_ == 0 ? 0 : count_ - 1)};
  }
  auto ticks = read_ticks();
  if (!ticks) return ticks.error();
  const std::uint64_t t0 = (*ticks)[begin];
  const std::uint64_t t1 = (*ticks)[end];
  if (t1 < t0) {
    return Error{"timestamp " + std::to_string(end) + " (" + std::to_string(t1) + ") is earlier than timestamp " +
                 std::to_string(begin) + " (" + std::to_string(t0) + ")"};
  }
  return static_cast<double>(t1 - t0) * context_->timestamp_period_ns();
}

}  // namespace gauss::vk
