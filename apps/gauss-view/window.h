#pragma once
// Window: the desktop viewer's GLFW window, its Vulkan surface and swapchain, the ImGui
// panels, camera input (input_state.h: fly and orbit), and per frame the present of a
// caller's image.
//
// Setup (the order matters: the surface needs the instance, the device choice needs the
// surface):
//   auto window = Window::create({...});            // GLFW + window, no Vulkan yet
//   vk::ContextCreateInfo ci; window->configure_context(ci);
//   auto context = vk::Context::create(ci);         // instance exts, swapchain, surface
//   window->attach(*context);                       // swapchain, ImGui
// Teardown: window->detach(); then destroy the Context; then the Window (GLFW goes last,
// so the surface dies before the X connection it was made on).
//
// Frame (one thread; `slot` is the frame ring's slot, whose previous frame the caller
// has waited for; see vk_swapchain.h for why):
//   window->poll_events();
//   if (!window->acquire(slot)) -> skip rendering (minimised / swapchain just recreated)
//   window->begin_ui();  ImGui::...;                // the panels
//   record the scene into `cmd`; window->record_present(cmd, source);  end `cmd`
//   window->submit_and_present(cmd, fence);
// record_present() records: the source image blitted into the swapchain image (scaled to
// fit, aspect kept, letterbox bars in the clear colour; a plain copy when size and format
// match), the UI on top, the transition to PRESENT_SRC_KHR. A caller with raw fences
// resets its fence only after acquire() succeeded (a skipped frame would otherwise leave
// it unsignalled). With vk::FrameRing: frame = ring.begin(); acquire(frame.index); if
// false, ring.abandon() (or ring.submit() work that presents nothing); else record,
// ring.end(), submit_and_present(frame.cmd, frame.fence), ring.submitted().
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_swapchain.h"
#include "input_state.h"

struct GLFWwindow;

namespace gauss::view {

class ImGuiLayer;
struct WindowCallbacks;

struct WindowCreateInfo {
  std::string title{"gauss-view"};
  int width{1280};   // screen coordinates (pixels on X11)
  int height{800};
  vk::PresentMode present_mode{vk::PresentMode::fifo};
  // Frames the caller keeps in flight (its frame ring's N); acquire(slot) takes slot < N.
  std::uint32_t frames_in_flight{2};
  // Colour of the letterbox bars and of frames without a source image (display-encoded).
  float clear_color[4]{0.08f, 0.08f, 0.09f, 1.0f};
};

// The image record_present() shows: RGBA8/BGRA8 (UNORM), in GENERAL or
// TRANSFER_SRC_OPTIMAL layout, which it keeps. `written_stage`/`written_access` describe
// the caller's last write to it (defaults: anything); record_present() adds the barrier
// from there to its transfer read. A later write to the image must wait for
// VK_PIPELINE_STAGE_2_TRANSFER_BIT (reads are done then). image == VK_NULL_HANDLE: only
// the clear colour (and the UI) is shown.
struct SourceImage {
  VkImage image{VK_NULL_HANDLE};
  VkImageLayout layout{VK_IMAGE_LAYOUT_GENERAL};
  VkExtent2D extent{0, 0};
  VkFormat format{VK_FORMAT_R8G8B8A8_UNORM};
  VkPipelineStageFlags2 written_stage{VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT};
  VkAccessFlags2 written_access{VK_ACCESS_2_MEMORY_WRITE_BIT};
};

// A screenshot's outcome: the PNG written to `path`, or why not.
struct ScreenshotResult {
  std::filesystem::path path;
  Status written{Ok{}};
};

// Where the source landed in the swapchain image (pixels).
struct Viewport {
  std::int32_t x{0}, y{0};
  std::uint32_t width{0}, height{0};
};

class Window {
 public:
  // Initialises GLFW and opens the window (no client API: Vulkan). Errors: no display
  // (the message names gauss-view's --headless option), no Vulkan support in GLFW, a
  // failed window creation.
  static Expected<std::unique_ptr<Window>> create(const WindowCreateInfo& info);
  // detach() if still attached (the Context must then still be alive), closes the
  // window, terminates GLFW.
  ~Window();
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;

  // Adds what presenting to this window needs: GLFW's instance extensions,
  // VK_KHR_swapchain, and the surface callback.
  void configure_context(vk::ContextCreateInfo& info);
  // Creates the swapchain (at the framebuffer size) and the ImGui layer. The context must
  // come from a ContextCreateInfo passed through configure_context().
  Status attach(vk::Context& context);
  // Waits for the queue, destroys the ImGui layer, the swapchain and the frame objects.
  void detach();

  GLFWwindow* handle() const noexcept { return window_; }
  bool should_close() const;
  void request_close();
  // Framebuffer size in pixels (0x0 while minimised).
  VkExtent2D framebuffer_extent() const;
  bool minimised() const;
  // Requests a new window size (screen coordinates); the swapchain follows on a later
  // acquire() once the window system has applied it.
  void set_size(int width, int height);

  // Processes window events and refreshes input().
  void poll_events();
  // Sleeps until an event or `timeout_s` (use while minimised instead of spinning).
  void wait_events(double timeout_s);
  const InputState& input() const noexcept { return input_; }
  // Raw key state (GLFW_KEY_*), not filtered by the UI; a press() counts as down until the
  // poll_events() after the one that saw it.
  bool key_down(int glfw_key) const;
  // Presses GLFW_KEY_* for the next poll_events(), through the same edge detection as the
  // keyboard (scripts and tests: gauss-view --press).
  void press(int glfw_key);

  // Files dropped on the window (GLFW's drop callback calls drop(); so does gauss-view
  // --drop), oldest first, since the last call.
  void drop(std::span<const std::string> paths);
  std::vector<std::filesystem::path> take_dropped() { return std::exchange(dropped_, {}); }
  void set_title(const std::string& title);

  // Recreates the swapchain when the framebuffer size changed or the last frame reported
  // it out of date, then acquires an image for frame slot `slot`. false: do not render
  // this frame (minimised, or the image could not be acquired right after recreating);
  // nothing was signalled then. Errors: as vk::Swapchain::acquire / recreate.
  Expected<bool> acquire(std::uint32_t slot);

  // Starts the UI frame; ImGui calls that follow build the panels shown by this frame's
  // record_present(). Without it the frame shows no UI.
  void begin_ui();

  // Records the present of `src` (+ UI) into `cmd` for the acquired image (see the header
  // comment). Errors (nothing recorded): no acquired image, a source layout other than
  // GENERAL / TRANSFER_SRC_OPTIMAL, a format that cannot be blitted.
  Status record_present(VkCommandBuffer cmd, const SourceImage& src);
  // Side by side (a stereo preview): the swapchain image is split into sources.size()
  // columns of equal width (0 .. kMaxSources), source i fitted into column i as above
  // (aspect kept, bars in the clear colour; a plain copy when it fills its column
  // exactly in the swapchain's format). One source is the overload above; none shows
  // only the clear colour. Errors: as above, more than kMaxSources.
  static constexpr std::size_t kMaxSources = 2;
  Status record_present(VkCommandBuffer cmd, std::span<const SourceImage> sources);
  // Submits `cmd` (ended) with the acquire/render-finished semaphores and `fence`, then
  // presents. When a screenshot was requested for this frame, waits for `fence` and
  // writes the PNG (a one-off stall; take_screenshot_result() says whether it was
  // written). Errors: submit/present failures, a failed fence wait.
  Status submit_and_present(VkCommandBuffer cmd, VkFence fence);

  // The next recorded frame is also read back (after the UI, before presenting) and
  // written to `path` by its submit_and_present(): the swapchain image exactly as shown,
  // bytes swizzled to RGBA. A presented image belongs to the display engine and cannot
  // be read afterwards, so the capture is of the next frame, not of the last one.
  // Fails at record time when the surface does not offer TRANSFER_SRC usage.
  void request_screenshot(const std::filesystem::path& path);
  // The last screenshot's outcome once its frame was submitted (an unwritable PNG is no
  // frame error: a viewer shows it and goes on), then nullopt until the next.
  std::optional<ScreenshotResult> take_screenshot_result() { return std::exchange(screenshot_result_, std::nullopt); }

  // Where the last record_present() put source `i` (empty when it had fewer sources).
  Viewport last_viewport(std::size_t i = 0) const noexcept { return i < kMaxSources ? viewports_[i] : Viewport{}; }
  const vk::Swapchain* swapchain() const noexcept { return swapchain_.get(); }
  ImGuiLayer* ui() noexcept { return ui_.get(); }

 private:
  friend struct WindowCallbacks;
  // A host-visible buffer the swapchain image is copied into for one screenshot.
  struct Readback {
    vk::Buffer buffer;  // host visible
    VkExtent2D extent{0, 0};
    VkFormat format{VK_FORMAT_UNDEFINED};
    std::filesystem::path path;
  };
  Window() = default;
  Status recreate_swapchain();
  Status record_screenshot_copy(VkCommandBuffer cmd, VkImage image);
  Status finish_screenshot(VkFence fence);

  WindowCreateInfo info_{};
  GLFWwindow* window_{nullptr};
  vk::Context* context_{nullptr};
  std::unique_ptr<vk::Swapchain> swapchain_;
  std::unique_ptr<ImGuiLayer> ui_;
  InputState input_{};
  double last_cursor_x_{0.0}, last_cursor_y_{0.0};
  double scroll_accum_{0.0};
  bool right_was_down_{false};
  bool view_key_was_down_[4]{};  // F, 1, 2, 3
  bool screenshot_was_down_{false};
  bool orbit_was_down_{false};
  bool left_was_down_{false}, middle_was_down_{false};
  double drag_cursor_x_{0.0}, drag_cursor_y_{0.0};
  VkExtent2D swapchain_for_{0, 0};  // framebuffer size the swapchain was last made for
  bool framebuffer_resized_{false};
  std::optional<std::uint32_t> image_index_;  // acquired, not yet presented
  Viewport viewports_[kMaxSources]{};
  std::optional<std::filesystem::path> screenshot_path_;
  std::unique_ptr<Readback> readback_;  // the capture recorded into the current frame
  std::optional<ScreenshotResult> screenshot_result_;
  std::vector<std::filesystem::path> dropped_;
  std::vector<int> pressed_, pressed_seen_;  // press(): for the next poll, and seen by the last one
};

}  // namespace gauss::view
