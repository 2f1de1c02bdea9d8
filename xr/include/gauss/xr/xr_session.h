#pragma once
// An OpenXR session rendering with the project's Vulkan context: the instance with
// XR_KHR_vulkan_enable2 (the Vulkan instance and device created through the runtime, volk
// loaded from them by vk::Context), the HMD system, a session driven through every state
// (idle, ready, synchronized, visible, focused, stopping, loss pending, exiting), the local
// or stage reference space, one colour swapchain per eye, and the frame loop:
// xrWaitFrame -> xrBeginFrame -> xrLocateViews at the predicted display time -> the caller
// renders both eyes and records the copy into the acquired swapchain images -> xrEndFrame
// with a projection layer. OpenXR poses and fields of view become engine cameras only
// through xr_pose.h.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <openxr/openxr.h>
#include <volk.h>

#include <glm/mat4x4.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/result.h"
#include "gauss/render/vk_context.h"

namespace gauss::xr {

struct HeadsetConfig {
  std::string app_name{"gauss-xr"};
  bool stage_space{false};      // STAGE reference space (floor origin) instead of LOCAL
  double near_plane{0.05};      // metres: the eye cameras' near plane
  double far_plane{1000.0};     // metres: their far plane (the depth layer's farZ)
  bool enable_validation{false};  // Vulkan validation (also GAUSS_VALIDATION=1)
};

// The session's state as the app sees it (OpenXR's XrSessionState, plus "ended").
enum class SessionPhase {
  Idle,          // created, or between runs: no frames
  Running,       // begun: frames are waited, begun and ended (rendered when visible)
  Stopping,      // the runtime asked to stop: the session has been ended, waiting for idle/exit
  LossPending,   // the runtime is losing the session: destroy and recreate, or exit
  Exiting,       // the runtime or the user asked to exit: leave the loop
};
const char* to_string(SessionPhase phase);

// One eye of a frame: the engine camera (OpenCV convention, from xr_pose.h) and the pose
// and field of view it came from, exactly as they go into the projection layer.
struct EyeView {
  Camera camera;
  XrPosef pose{};
  XrFovf fov{};
};

// What the caller gets for a rendered frame: both eyes and the swapchain images to fill
// (each in COLOR_ATTACHMENT_OPTIMAL, and must be left so by the recorded commands).
struct FrameTarget {
  XrTime display_time{0};
  std::array<EyeView, 2> eyes{};
  std::array<VkImage, 2> images{};
  VkExtent2D extent{};
  VkFormat format{VK_FORMAT_UNDEFINED};
  // With XR_KHR_composition_layer_depth: each eye's D32_SFLOAT depth image (in
  // DEPTH_STENCIL_ATTACHMENT_OPTIMAL, to be left so), filled with the projected depth for
  // near_z / far_z (render::DepthProjection). VK_NULL_HANDLE without the extension.
  std::array<VkImage, 2> depth_images{VK_NULL_HANDLE, VK_NULL_HANDLE};
  double near_z{0.0}, far_z{0.0};
};

class HeadsetSession {
 public:
  // Instance, system, Vulkan context, session, space and swapchains. Errors (readable, with
  // the XrResult): no runtime (XR_RUNTIME_JSON unset and none active), a runtime without
  // XR_KHR_vulkan_enable2, no HMD, a Vulkan device the renderer cannot use, no swapchain
  // format the renderer can copy into.
  static Expected<std::unique_ptr<HeadsetSession>> create(const HeadsetConfig& config);
  ~HeadsetSession();
  HeadsetSession(const HeadsetSession&) = delete;
  HeadsetSession& operator=(const HeadsetSession&) = delete;

  vk::Context& context() noexcept { return *context_; }
  XrInstance instance() const noexcept { return instance_; }
  ::XrSession handle() const noexcept { return session_; }
  XrSpace space() const noexcept { return space_; }
  std::uint32_t eye_width() const noexcept { return width_; }
  std::uint32_t eye_height() const noexcept { return height_; }
  bool depth_layer() const noexcept { return depth_layer_; }
  const std::string& runtime_name() const noexcept { return runtime_name_; }

  // Drains the runtime's events and acts on state changes (begins the session when ready,
  // ends it when stopping). Errors: a failed xrBeginSession/xrEndSession, instance loss.
  Expected<SessionPhase> poll();
  // Every session state the runtime reported, in order ("READY", "FOCUSED", ...).
  const std::vector<std::string>& states_seen() const noexcept { return states_seen_; }
  // Asks the runtime to end the session (xrRequestExitSession): poll() then reaches Exiting.
  Status request_exit();

  // One frame while Running: waits, begins, locates the views and, when the runtime says
  // to render, acquires both images, calls `render` (which must have submitted its commands
  // when it returns) and releases them; then ends the frame (with the projection layer, or
  // none). Returns whether `render` ran. Errors: any failing call, named; a lost session
  // (XR_ERROR_SESSION_LOST) is reported as phase LossPending by the next poll().
  Expected<bool> frame(const std::function<Status(const FrameTarget&)>& render);
  // A status banner (a small amber quad layer fixed in view, above the line of sight) on
  // every rendered frame from now on, or none: what the headset shows while the host is
  // unreachable, since there is no window to print to.
  void show_banner(bool on) noexcept { banner_on_ = on; }
  // Maps the reference space into the scene for the eye cameras (eye_camera's T_scene_space;
  // scene_from_space turns a scene upright): identity until set.
  void set_scene_from_space(const glm::dmat4& t) noexcept { scene_from_space_ = t; }
  const glm::dmat4& scene_from_space() const noexcept { return scene_from_space_; }
  bool banner_shown() const noexcept { return banner_on_; }
  std::uint64_t frames_ended() const noexcept { return frames_ended_; }

 private:
  HeadsetSession() = default;
  Status create_swapchains();
  // One swapchain of `format` (usage plus TRANSFER_DST), its images into `images` if given.
  Status make_swapchain(VkFormat format, XrSwapchainUsageFlags usage, std::uint32_t width, std::uint32_t height,
                        XrSwapchain& out, std::vector<VkImage>* images);
  Expected<std::vector<VkImage>> swapchain_images(XrSwapchain swapchain) const;
  Status prepare_banner();
  Status end_frame(XrTime display_time, bool with_layer, const FrameTarget* target);
  void destroy_session();

  HeadsetConfig config_;
  XrInstance instance_{XR_NULL_HANDLE};
  XrSystemId system_{XR_NULL_SYSTEM_ID};
  std::unique_ptr<vk::Context> context_;
  ::XrSession session_{XR_NULL_HANDLE};
  XrSpace space_{XR_NULL_HANDLE};
  std::array<XrSwapchain, 2> swapchains_{XR_NULL_HANDLE, XR_NULL_HANDLE};
  std::array<std::vector<VkImage>, 2> images_;
  bool depth_layer_{false};  // XR_KHR_composition_layer_depth enabled and D32_SFLOAT offered
  std::array<XrSwapchain, 2> depth_swapchains_{XR_NULL_HANDLE, XR_NULL_HANDLE};
  std::array<std::vector<VkImage>, 2> depth_images_;
  VkFormat format_{VK_FORMAT_UNDEFINED};
  std::uint32_t width_{0}, height_{0};
  std::string runtime_name_;
  SessionPhase phase_{SessionPhase::Idle};
  std::uint64_t frames_ended_{0};
  std::vector<std::string> states_seen_;
  XrSwapchain banner_{XR_NULL_HANDLE};
  XrSpace view_space_{XR_NULL_HANDLE};
  glm::dmat4 scene_from_space_{1.0};
  bool banner_on_{false};
  bool banner_ready_{false};  // its one image was filled and released
};

}  // namespace gauss::xr
