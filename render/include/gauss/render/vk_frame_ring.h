#pragma once
// gauss::vk::FrameRing: N frames in flight on the one queue. Each slot owns a command
// buffer and a fence; frames get increasing serials (1, 2, 3, ...) and are submitted
// in serial order, so "frame S finished" implies every frame before it finished.
//
// begin() waits only for the frame that last used the slot (serial - N), never for the
// whole device: recording frame k+1 overlaps the GPU work of frame k. Objects the GPU
// may still read (a replaced mesh chunk, an outgrown staging block) are handed to
// defer(): they are destroyed once every frame that could have used them has finished.
//
// Submission: submit() ends and submits with no semaphores (offscreen frames). A
// presenter that must wait/signal semaphores calls end(), submits the command buffer
// itself with the frame's fence (the fence is unsignalled at that point), then
// submitted(). Until submitted() the frame counts as being recorded.
//
// Threading: one thread (the display loop).
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;

inline constexpr std::uint32_t kMaxFramesInFlight = 4;

class FrameRing {
 public:
  struct Frame {
    VkCommandBuffer cmd{VK_NULL_HANDLE};
    VkFence fence{VK_NULL_HANDLE};  // unsignalled while the frame is recorded
    std::uint64_t serial{0};
    std::uint32_t index{0};  // slot: serial % frames_in_flight
  };

  // Errors: frames_in_flight outside 1..kMaxFramesInFlight, Vulkan failures.
  static Expected<std::unique_ptr<FrameRing>> create(Context& context, std::uint32_t frames_in_flight);
  // Waits for every submitted frame, runs every deferral, frees the slots.
  ~FrameRing();
  FrameRing(const FrameRing&) = delete;
  FrameRing& operator=(const FrameRing&) = delete;

  std::uint32_t frames_in_flight() const noexcept { return static_cast<std::uint32_t>(slots_.size()); }

  // Starts the next frame: waits for the slot's previous frame, runs the deferrals
  // that are now safe, begins the command buffer. Errors: a frame already being
  // recorded, Vulkan failures (device lost is reported, never hidden).
  Expected<Frame> begin();
  bool recording() const noexcept { return recording_; }
  // The frame being recorded (valid only while recording()).
  const Frame& current() const noexcept { return current_; }

  // Ends and submits the current frame (no semaphores), signalling its fence.
  Status submit();
  // Presenter path: end() the command buffer, submit it yourself with current().fence,
  // then submitted().
  Status end();
  void submitted();
  // Gives up the current frame without submitting it (after a recording error): the
  // command buffer is reset and the serial is not used.
  void abandon() noexcept;

  // Serial of the frame being recorded, or of the next one when none is.
  std::uint64_t recording_serial() const noexcept { return next_serial_; }
  // Newest serial known to have finished (0 = none yet). Updated by begin(), poll()
  // and wait().
  std::uint64_t completed_serial() const noexcept { return completed_; }
  std::uint64_t submitted_serial() const noexcept { return next_serial_ - 1; }
  // Checks the fences without blocking; returns completed_serial().
  std::uint64_t poll();
  // Blocks until frame `serial` has finished (a serial never submitted is an error).
  Status wait(std::uint64_t serial);
  // Blocks until every submitted frame has finished (shutdown, readbacks; not for the
  // frame path).
  Status wait_all();

  // Runs `destroy` once every frame submitted so far and the one being recorded have
  // finished (at the latest in the destructor); with nothing in flight, at the next
  // begin() / wait().
  void defer(std::function<void()> destroy);
  // Runs `destroy` once frame `serial` (so every frame before it) has finished, e.g. the
  // next frame to be recorded when that frame will still read the object. Deferrals run
  // in the order they were made, none before its frame.
  void defer_until(std::uint64_t serial, std::function<void()> destroy);
  std::size_t deferred_count() const noexcept { return deferred_.size(); }

 private:
  struct Slot {
    VkCommandBuffer cmd{VK_NULL_HANDLE};
    VkFence fence{VK_NULL_HANDLE};
    std::uint64_t serial{0};  // last frame submitted from this slot (0 = none)
    bool in_flight{false};
  };
  explicit FrameRing(Context& context) : context_(&context) {}
  Status wait_slot(Slot& slot);
  void run_deferred();

  Context* context_;
  std::vector<Slot> slots_;
  std::uint64_t next_serial_{1};
  std::uint64_t completed_{0};
  bool recording_{false};
  Frame current_{};
  struct Deferred {
    std::uint64_t after_serial;
    std::function<void()> destroy;
  };
  std::deque<Deferred> deferred_;
};

}  // namespace gauss::vk
