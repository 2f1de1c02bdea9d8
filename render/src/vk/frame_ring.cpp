// FrameRing: command buffers + fences of the frames in flight, and deferred destruction.
#include "gauss/render/vk_frame_ring.h"

#include <string>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"

namespace gauss::vk {

Expected<std::unique_ptr<FrameRing>> FrameRing::create(Context& context, std::uint32_t frames_in_flight) {
  if (frames_in_flight == 0 || frames_in_flight > kMaxFramesInFlight)
    return Error{"FrameRing: frames_in_flight " + std::to_string(frames_in_flight) + " outside 1.." +
                 std::to_string(kMaxFramesInFlight)};
  std::unique_ptr<FrameRing> ring(new FrameRing(context));
  ring->slots_.resize(frames_in_flight);
  for (Slot& s : ring->slots_) {
    auto cmd = allocate_command_buffer(context, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
    if (!cmd) return cmd.error();
    s.cmd = *cmd;
    VkFenceCreateInfo fci{};
    fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    GAUSS_VK_TRY(vkCreateFence(context.device(), &fci, nullptr, &s.fence));
  }
  return ring;
}

FrameRing::~FrameRing() {
  if (recording_) abandon();
  (void)wait_all();
  // Whatever is left may have been deferred after the last submission: nothing runs now.
  while (!deferred_.empty()) {
    deferred_.front().destroy();
    deferred_.pop_front();
  }
  const VkDevice device = context_->device();
  for (Slot& s : slots_) {
    if (s.fence) vkDestroyFence(device, s.fence, nullptr);
    if (s.cmd) vkFreeCommandBuffers(device, context_->command_pool(), 1, &s.cmd);
  }
}

Status FrameRing::wait_slot(Slot& slot) {
  if (!slot.in_flight) return Ok{};
  GAUSS_VK_TRY(vkWaitForFences(context_->device(), 1, &slot.fence, VK_TRUE, UINT64_MAX));
  slot.in_flight = false;
  // Frames finish in submission order on the one queue.
  if (slot.serial > completed_) completed_ = slot.serial;
  return Ok{};
}

void FrameRing::run_deferred() {
  while (!deferred_.empty() && deferred_.front().after_serial <= completed_) {
    auto destroy = std::move(deferred_.front().destroy);
    deferred_.pop_front();
    destroy();
  }
}

Expected<FrameRing::Frame> FrameRing::begin() {
  if (recording_) return Error{"FrameRing::begin: frame " + std::to_string(next_serial_) + " is still being recorded"};
  const std::uint64_t serial = next_serial_;
  const auto index = static_cast<std::uint32_t>(serial % slots_.size());
  Slot& slot = slots_[index];
  if (auto st = wait_slot(slot); !st) return st.error();
  (void)poll();
  run_deferred();
  GAUSS_VK_TRY(vkResetFences(context_->device(), 1, &slot.fence));
  GAUSS_VK_TRY(vkResetCommandBuffer(slot.cmd, 0));
  VkCommandBufferBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  GAUSS_VK_TRY(vkBeginCommandBuffer(slot.cmd, &bi));
  recording_ = true;
  current_ = Frame{slot.cmd, slot.fence, serial, index};
  return current_;
}

Status FrameRing::end() {
  if (!recording_) return Error{"FrameRing::end: no frame is being recorded"};
  GAUSS_VK_TRY(vkEndCommandBuffer(current_.cmd));
  return Ok{};
}

void FrameRing::submitted() {
  Slot& slot = slots_[current_.index];
  slot.serial = current_.serial;
  slot.in_flight = true;
  recording_ = false;
  ++next_serial_;
}

Status FrameRing::submit() {
  if (auto st = end(); !st) return st;
  if (auto st = context_->submit(current_.cmd, current_.fence); !st) {
    abandon();
    return st;
  }
  submitted();
  return Ok{};
}

void FrameRing::abandon() noexcept {
  if (!recording_) return;
  (void)vkResetCommandBuffer(current_.cmd, 0);
  recording_ = false;
}

std::uint64_t FrameRing::poll() {
  for (Slot& s : slots_) {
    if (s.in_flight && vkGetFenceStatus(context_->device(), s.fence) == VK_SUCCESS) {
      s.in_flight = false;
      if (s.serial > completed_) completed_ = s.serial;
    }
  }
  return completed_;
}

Status FrameRing::wait(std::uint64_t serial) {
  if (serial == 0 || serial > submitted_serial())
    return Error{"FrameRing::wait: frame " + std::to_string(serial) + " was never submitted (last " +
                 std::to_string(submitted_serial()) + ")"};
  if (serial <= completed_) return Ok{};
  for (Slot& s : slots_)
    if (s.in_flight && s.serial <= serial)
      if (auto st = wait_slot(s); !st) return st;
  run_deferred();
  return Ok{};
}

Status FrameRing::wait_all() {
  for (Slot& s : slots_)
    if (auto st = wait_slot(s); !st) return st;
  if (!recording_) run_deferred();
  return Ok{};
}

void FrameRing::defer(std::function<void()> destroy) {
  // The frame being recorded (else the last one submitted) is the last that could use
  // the object.
  defer_until(recording_ ? next_serial_ : next_serial_ - 1, std::move(destroy));
}

void FrameRing::defer_until(std::uint64_t serial, std::function<void()> destroy) {
  deferred_.push_back(Deferred{serial, std::move(destroy)});
}

}  // namespace gauss::vk
