#pragma once
// Reading back what the app submitted (GAUSS_XR_HEADLESS_CAPTURE=<folder>): at a captured
// xrEndFrame each projection view's subImage is copied from its swapchain image into
//   <folder>/frame-<6-digit index>-eye<0|1>.rgba   rows top to bottom, 4 bytes per pixel
//                                                  (R, G, B, A; B8G8R8A8 images are swizzled)
//   <folder>/frame-<6-digit index>.json            sizes, format, times, poses and fovs as submitted
// and xrDestroySession writes <folder>/session.json (states passed through, frame counts).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "gauss/engine/result.h"
#include "runtime.h"

namespace gauss::xr_headless {

struct CapturedDepth {
  const Swapchain* swapchain{nullptr};
  XrRect2Di rect{};
  std::uint32_t array_index{0};
  float min_depth{0}, max_depth{1}, near_z{0}, far_z{0};
};

struct CapturedView {
  const Swapchain* swapchain{nullptr};  // its last released image is what the layer shows
  XrRect2Di rect{};
  std::uint32_t array_index{0};
  XrPosef pose{};
  XrFovf fov{};
  std::optional<CapturedDepth> depth;
};

struct CapturedFrame {
  std::uint64_t index{0};
  XrTime predicted_display_time{0};
  XrTime display_time{0};  // as submitted in XrFrameEndInfo
  std::string space;       // the layer's space, e.g. "XR_REFERENCE_SPACE_TYPE_STAGE" or "action"
  XrCompositionLayerFlags layer_flags{0};
  std::vector<CapturedView> views;
};

// Copies the views' pixels (on the app's queue, after vkQueueWaitIdle) and writes the files.
Status capture_frame(VulkanDevice& vk, const std::filesystem::path& dir, const CapturedFrame& frame);

Status write_session_summary(const Session& session, const std::filesystem::path& dir);

}  // namespace gauss::xr_headless
