// Window: GLFW setup, the Vulkan surface and swapchain lifecycle, resize/minimise,
// camera input. The per-frame present recording is in window_present.cpp.
#include "window.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gauss/render/vk_check.h"
#include "glfw.h"
#include "imgui_layer.h"

namespace gauss::view {
namespace {

std::string glfw_error_text() {
  const char* description = nullptr;
  const int code = glfwGetError(&description);
  if (code == GLFW_NO_ERROR) return "no error reported";
  return description != nullptr ? std::string(description) : "GLFW error " + std::to_string(code);
}

Window* from(GLFWwindow* w) { return static_cast<Window*>(glfwGetWindowUserPointer(w)); }

}  // namespace

// Callbacks installed before ImGui's GLFW backend, which chains them.
struct WindowCallbacks {
  static void framebuffer_size(GLFWwindow* w, int, int) {
    if (Window* self = from(w)) self->framebuffer_resized_ = true;
  }
  static void scroll(GLFWwindow* w, double, double dy) {
    if (Window* self = from(w)) self->scroll_accum_ += dy;
  }
  static void drop(GLFWwindow* w, int count, const char** paths) {
    Window* self = from(w);
    if (self == nullptr || count <= 0) return;
    const std::vector<std::string> names(paths, paths + count);
    self->drop(names);
  }
};

Expected<std::unique_ptr<Window>> Window::create(const WindowCreateInfo& info) {
  if (info.width <= 0 || info.height <= 0) {
    return Error{"window size " + std::to_string(info.width) + "x" + std::to_string(info.height) + " must be positive"};
  }
  if (glfwInit() != GLFW_TRUE) {
    return Error{"gauss-view cannot open a window: no display (" + glfw_error_text() +
                 "). Run gauss-view --headless to stream and render without a window, or start it under "
                 "a display (e.g. xvfb-run)"};
  }
  if (glfwVulkanSupported() != GLFW_TRUE) {
    const std::string why = glfw_error_text();
    glfwTerminate();
    return Error{"GLFW found no Vulkan loader for window surfaces (" + why + "); gauss-view --headless needs none"};
  }
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
  std::unique_ptr<Window> win(new Window());
  win->info_ = info;
  win->window_ = glfwCreateWindow(info.width, info.height, info.title.c_str(), nullptr, nullptr);
  if (win->window_ == nullptr) {
    const std::string why = glfw_error_text();
    glfwTerminate();
    return Error{"creating the " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                 " window failed (" + why + "); gauss-view --headless runs without one"};
  }
  glfwSetWindowUserPointer(win->window_, win.get());
  glfwSetFramebufferSizeCallback(win->window_, WindowCallbacks::framebuffer_size);
  glfwSetScrollCallback(win->window_, WindowCallbacks::scroll);
  glfwSetDropCallback(win->window_, WindowCallbacks::drop);
  return win;
}

Window::~Window() {
  if (context_ != nullptr) detach();
  if (window_ != nullptr) {
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
}

void Window::configure_context(vk::ContextCreateInfo& info) {
  std::uint32_t count = 0;
  const char** names = glfwGetRequiredInstanceExtensions(&count);
  for (std::uint32_t i = 0; i < count; ++i) info.instance_extensions.emplace_back(names[i]);
  info.device_extensions.emplace_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  GLFWwindow* window = window_;
  info.create_surface = [window](VkInstance instance) -> Expected<VkSurfaceKHR> {
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    if (const VkResult r = glfwCreateWindowSurface(instance, window, nullptr, &surface); r != VK_SUCCESS) {
      return Error{std::string("glfwCreateWindowSurface failed with ") + vk::result_name(r) + " (" +
                   glfw_error_text() + ")"};
    }
    return surface;
  };
}

Status Window::attach(vk::Context& context) {
  if (context_ != nullptr) return Error{"Window::attach: already attached"};
  if (context.surface() == VK_NULL_HANDLE) {
    return Error{"Window::attach: the context has no surface (pass its ContextCreateInfo through configure_context)"};
  }
  context_ = &context;
  vk::SwapchainCreateInfo sci;
  sci.extent = framebuffer_extent();
  sci.present_mode = info_.present_mode;
  sci.frames_in_flight = info_.frames_in_flight;
  auto sc = vk::Swapchain::create(context, sci);
  if (!sc) {
    context_ = nullptr;
    return sc.error();
  }
  swapchain_ = std::move(*sc);
  swapchain_for_ = sci.extent;
  framebuffer_resized_ = false;
  // The render pass needs the format; a minimised start has no images yet, so assume the
  // preferred one then (set_targets() reports a mismatch later).
  const VkFormat format = swapchain_->empty() ? VK_FORMAT_B8G8R8A8_UNORM : swapchain_->format();
  auto ui = ImGuiLayer::create(context, window_, format, info_.frames_in_flight);
  if (!ui) {
    detach();
    return ui.error();
  }
  ui_ = std::move(*ui);
  if (!swapchain_->empty()) {
    if (auto st = ui_->set_targets(swapchain_->views(), swapchain_->extent(), swapchain_->format()); !st) {
      detach();
      return st;
    }
  }
  return Ok{};
}

void Window::detach() {
  if (context_ == nullptr) return;
  // Teardown cannot report an error; a lost device shows up in the context's destructor.
  (void)vkQueueWaitIdle(context_->queue());
  ui_.reset();
  swapchain_.reset();
  readback_.reset();
  image_index_.reset();
  context_ = nullptr;
}

bool Window::should_close() const { return glfwWindowShouldClose(window_) == GLFW_TRUE; }
void Window::request_close() { glfwSetWindowShouldClose(window_, GLFW_TRUE); }

VkExtent2D Window::framebuffer_extent() const {
  int w = 0;
  int h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  return {static_cast<std::uint32_t>(w > 0 ? w : 0), static_cast<std::uint32_t>(h > 0 ? h : 0)};
}

bool Window::minimised() const {
  const VkExtent2D e = framebuffer_extent();
  return e.width == 0 || e.height == 0 || glfwGetWindowAttrib(window_, GLFW_ICONIFIED) == GLFW_TRUE;
}

void Window::set_size(int width, int height) { glfwSetWindowSize(window_, width, height); }

bool Window::key_down(int glfw_key) const {
  return glfwGetKey(window_, glfw_key) == GLFW_PRESS ||
         std::find(pressed_seen_.begin(), pressed_seen_.end(), glfw_key) != pressed_seen_.end();
}

void Window::press(int glfw_key) { pressed_.push_back(glfw_key); }

void Window::drop(std::span<const std::string> paths) {
  for (const std::string& p : paths) dropped_.emplace_back(p);
}

void Window::set_title(const std::string& title) { glfwSetWindowTitle(window_, title.c_str()); }

void Window::wait_events(double timeout_s) {
  glfwWaitEventsTimeout(timeout_s);
  poll_events();
}

void Window::poll_events() {
  glfwPollEvents();
  // An injected press is down for this poll only: the next one sees its release.
  pressed_seen_ = std::exchange(pressed_, {});
  InputState in;
  in.ui_wants_mouse = ui_ != nullptr && ui_->wants_mouse();
  in.ui_wants_keyboard = ui_ != nullptr && ui_->wants_keyboard();
  if (!in.ui_wants_keyboard) {
    in.forward = key_down(GLFW_KEY_W);
    in.back = key_down(GLFW_KEY_S);
    in.left = key_down(GLFW_KEY_A);
    in.right = key_down(GLFW_KEY_D);
    in.up = key_down(GLFW_KEY_E);
    in.down = key_down(GLFW_KEY_Q);
    in.fast = key_down(GLFW_KEY_LEFT_SHIFT) || key_down(GLFW_KEY_RIGHT_SHIFT);
  }
  // F, 1, 2, 3, O and P act once per press, not once per frame while held.
  const auto pressed = [&](int key, bool& was_down) {
    const bool down = !in.ui_wants_keyboard && key_down(key);
    const bool edge = down && !was_down;
    was_down = down;
    return edge;
  };
  const bool f = pressed(GLFW_KEY_F, view_key_was_down_[0]);  // both read: each keeps its edge
  if (pressed(GLFW_KEY_1, view_key_was_down_[1]) || f) in.view = ViewPreset::Front;
  if (pressed(GLFW_KEY_2, view_key_was_down_[2])) in.view = ViewPreset::Side;
  if (pressed(GLFW_KEY_3, view_key_was_down_[3])) in.view = ViewPreset::Top;
  in.toggle_orbit = pressed(GLFW_KEY_O, orbit_was_down_);
  in.screenshot = pressed(GLFW_KEY_P, screenshot_was_down_);
  // Left (orbit) and middle (pan) drags, like mouse look, start only with a press over the
  // scene, so that dragging a panel's slider never turns the view. The cursor stays visible.
  const bool left_down = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  const bool middle_down = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  in.dragging = left_down && (input_.dragging || (!left_was_down_ && !in.ui_wants_mouse));
  in.panning = middle_down && (input_.panning || (!middle_was_down_ && !in.ui_wants_mouse));
  {
    double x = 0.0;
    double y = 0.0;
    glfwGetCursorPos(window_, &x, &y);
    if ((in.dragging && input_.dragging) || (in.panning && input_.panning)) {
      in.drag_dx = x - drag_cursor_x_;
      in.drag_dy = y - drag_cursor_y_;
    }
    drag_cursor_x_ = x;
    drag_cursor_y_ = y;
  }
  left_was_down_ = left_down;
  middle_was_down_ = middle_down;
  // Mouse look starts only with a press over the scene (not one that began on a panel)
  // and lasts while the button is held; the cursor is captured meanwhile.
  const bool right_down = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  if (right_down && !right_was_down_ && !in.ui_wants_mouse && !input_.looking) {
    glfwSetInputMode(window_, GLFW_CURSOR, GLFW_CURSOR_DISABLED);
    glfwGetCursorPos(window_, &last_cursor_x_, &last_cursor_y_);
    in.looking = true;
  } else if (input_.looking && right_down) {
    double x = 0.0;
    double y = 0.0;
    glfwGetCursorPos(window_, &x, &y);
    in.look_dx = x - last_cursor_x_;
    in.look_dy = y - last_cursor_y_;
    last_cursor_x_ = x;
    last_cursor_y_ = y;
    in.looking = true;
  } else if (input_.looking) {
    glfwSetInputMode(window_, GLFW_CURSOR, GLFW_CURSOR_NORMAL);
  }
  right_was_down_ = right_down;
  if (!in.ui_wants_mouse || in.looking) in.scroll = scroll_accum_;
  scroll_accum_ = 0.0;
  input_ = in;
}

Status Window::recreate_swapchain() {
  const VkExtent2D fb = framebuffer_extent();
  if (auto st = swapchain_->recreate(fb); !st) return st;
  swapchain_for_ = fb;
  framebuffer_resized_ = false;
  if (swapchain_->empty()) return Ok{};
  return ui_->set_targets(swapchain_->views(), swapchain_->extent(), swapchain_->format());
}

Expected<bool> Window::acquire(std::uint32_t slot) {
  if (context_ == nullptr) return Error{"Window::acquire: not attached to a context"};
  if (image_index_) return Error{"Window::acquire: the previous frame was not submitted"};
  const VkExtent2D fb = framebuffer_extent();
  if (fb.width == 0 || fb.height == 0) return false;  // minimised: keep everything, draw nothing
  const bool size_changed = fb.width != swapchain_for_.width || fb.height != swapchain_for_.height;
  if (framebuffer_resized_ || size_changed || swapchain_->needs_recreate() || swapchain_->empty()) {
    if (auto st = recreate_swapchain(); !st) return st.error();
    if (swapchain_->empty()) return false;
  }
  for (int attempt = 0; attempt < 2; ++attempt) {
    auto acquired = swapchain_->acquire(slot);
    if (!acquired) return acquired.error();
    switch (acquired->status) {
      case vk::Swapchain::AcquireStatus::acquired:
        image_index_ = acquired->image_index;
        return true;
      case vk::Swapchain::AcquireStatus::skip:
        return false;
      case vk::Swapchain::AcquireStatus::recreate:
        if (auto st = recreate_swapchain(); !st) return st.error();
        if (swapchain_->empty()) return false;
        break;
    }
  }
  return false;
}

void Window::begin_ui() {
  if (ui_ != nullptr) ui_->begin_frame();
}

}  // namespace gauss::view
