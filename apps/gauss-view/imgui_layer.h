#pragma once
// ImGuiLayer: Dear ImGui (Debian's 1.86) on a GLFW window, drawn with Vulkan into the
// swapchain images on top of the scene.
//
// ImGui 1.86's Vulkan backend predates its dynamic-rendering option, so the layer owns a
// one-subpass render pass (colour only, LOAD/STORE, COLOR_ATTACHMENT_OPTIMAL in and out:
// the caller's barriers do every layout change) and one framebuffer per swapchain image,
// rebuilt by set_targets() after each swapchain recreation.
//
// Frame: begin_frame() (after glfwPollEvents) -> ImGui:: calls -> record(cmd, image)
// inside the caller's command buffer with the image in COLOR_ATTACHMENT_OPTIMAL. A frame
// that is begun but not recorded is ended by the next begin_frame().
//
// Vertex/index buffers: the backend keeps a ring of `frames_in_flight` of them (its
// ImageCount) and rewrites the oldest each record(); that frame's fence has signalled
// by then because the caller waits for slot k-N before recording frame k.
//
// One ImGuiLayer per process (ImGui's backends keep global state). Must be destroyed
// before the Context and before the GLFW window.
#include <cstdint>
#include <memory>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"

struct GLFWwindow;

namespace gauss::vk {
class Context;
}

namespace gauss::view {

class ImGuiLayer {
 public:
  // Creates the ImGui context, the GLFW backend (installs its input callbacks, chaining
  // the window's own), the render pass for `color_format`, the Vulkan backend, and
  // uploads the font atlas (blocking). Errors: a second layer in the process, a failed
  // Vulkan call, a backend that cannot load its Vulkan functions.
  static Expected<std::unique_ptr<ImGuiLayer>> create(vk::Context& context, GLFWwindow* window,
                                                      VkFormat color_format, std::uint32_t frames_in_flight);
  ~ImGuiLayer();
  ImGuiLayer(const ImGuiLayer&) = delete;
  ImGuiLayer& operator=(const ImGuiLayer&) = delete;

  // Framebuffers for these image views (all `extent`); destroys the previous ones, which
  // the GPU must be done with (the swapchain waits for the queue before recreating).
  // Errors: a format other than the one of create() (the render pass would not match).
  Status set_targets(const std::vector<VkImageView>& views, VkExtent2D extent, VkFormat format);

  // Starts a UI frame (ends an unrecorded previous one first).
  void begin_frame();
  bool frame_begun() const noexcept { return frame_begun_; }

  // Finishes the UI frame and records its draw into target `index` (set_targets order).
  // Records nothing when no frame was begun. The image must be in COLOR_ATTACHMENT_OPTIMAL
  // with earlier writes made visible to COLOR_ATTACHMENT_OUTPUT; it stays in that layout.
  void record(VkCommandBuffer cmd, std::uint32_t index);

  // True while ImGui wants the mouse / keyboard (the cursor is over a panel, a text field
  // has focus): camera input should then be ignored.
  bool wants_mouse() const;
  bool wants_keyboard() const;

 private:
  ImGuiLayer() = default;
  void destroy_framebuffers() noexcept;

  vk::Context* context_{nullptr};
  VkFormat format_{VK_FORMAT_UNDEFINED};
  VkRenderPass render_pass_{VK_NULL_HANDLE};
  VkDescriptorPool descriptor_pool_{VK_NULL_HANDLE};
  std::vector<VkFramebuffer> framebuffers_;
  VkExtent2D extent_{0, 0};
  bool glfw_backend_{false};
  bool vulkan_backend_{false};
  bool frame_begun_{false};
};

}  // namespace gauss::view
