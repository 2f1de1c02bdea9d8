// ImGuiLayer: ImGui context + GLFW/Vulkan backends, render pass, framebuffers, font
// upload, per-frame UI recording. Contract in imgui_layer.h.
#include "imgui_layer.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"

namespace gauss::view {
namespace {

std::atomic<bool> g_layer_alive{false};

// The backend cannot return errors; a failed call there is fatal, like GAUSS_VK_CHECK.
void check_backend_result(VkResult r) {
  if (r < 0) {
    std::fprintf(stderr, "ImGui Vulkan backend: a Vulkan call failed with %s\n", vk::result_name(r));
    std::abort();
  }
}

// Instance functions first; device-level extension functions the loader does not hand
// out through the instance come from the device.
PFN_vkVoidFunction load_function(const char* name, void* user) {
  const auto* ctx = static_cast<const vk::Context*>(user);
  if (PFN_vkVoidFunction f = vkGetInstanceProcAddr(ctx->instance(), name)) return f;
  return vkGetDeviceProcAddr(ctx->device(), name);
}

}  // namespace

Expected<std::unique_ptr<ImGuiLayer>> ImGuiLayer::create(vk::Context& context, GLFWwindow* window,
                                                         VkFormat color_format, std::uint32_t frames_in_flight) {
  if (g_layer_alive.exchange(true)) return Error{"ImGuiLayer: only one per process (ImGui keeps global state)"};
  std::unique_ptr<ImGuiLayer> layer(new ImGuiLayer());
  layer->context_ = &context;
  layer->format_ = color_format;

  IMGUI_CHECKVERSION();  // Debian's libimgui.a against these headers
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // no imgui.ini in the working directory
  ImGui::StyleColorsDark();
  if (!ImGui_ImplGlfw_InitForVulkan(window, true)) return Error{"ImGui_ImplGlfw_InitForVulkan failed"};
  layer->glfw_backend_ = true;

  const VkDevice dev = context.device();
  VkAttachmentDescription color{};
  color.format = color_format;
  color.samples = VK_SAMPLE_COUNT_1_BIT;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  color.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.finalLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass{};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &ref;
  VkRenderPassCreateInfo rpci{};
  rpci.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
  rpci.attachmentCount = 1;
  rpci.pAttachments = &color;
  rpci.subpassCount = 1;
  rpci.pSubpasses = &subpass;
  GAUSS_VK_TRY(vkCreateRenderPass(dev, &rpci, nullptr, &layer->render_pass_));
  context.set_debug_name(VK_OBJECT_TYPE_RENDER_PASS, reinterpret_cast<std::uint64_t>(layer->render_pass_),
                         "imgui render pass");

  // The font atlas takes one set; room for a few UI textures later.
  const VkDescriptorPoolSize pool_size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 16};
  VkDescriptorPoolCreateInfo dpci{};
  dpci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  dpci.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  dpci.maxSets = 16;
  dpci.poolSizeCount = 1;
  dpci.pPoolSizes = &pool_size;
  GAUSS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, &layer->descriptor_pool_));

  if (!ImGui_ImplVulkan_LoadFunctions(load_function, &context)) {
    return Error{"ImGui_ImplVulkan_LoadFunctions: a Vulkan function of the ImGui backend is unavailable"};
  }
  ImGui_ImplVulkan_InitInfo init{};
  init.Instance = context.instance();
  init.PhysicalDevice = context.physical_device();
  init.Device = dev;
  init.QueueFamily = context.queue_family();
  init.Queue = context.queue();
  init.PipelineCache = VK_NULL_HANDLE;
  init.DescriptorPool = layer->descriptor_pool_;
  init.Subpass = 0;
  init.MinImageCount = 2;
  // The backend's ring of vertex/index buffers (see the header): one per frame in flight.
  init.ImageCount = std::max(2u, frames_in_flight);
  init.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  init.Allocator = nullptr;
  init.CheckVkResultFn = check_backend_result;
  if (!ImGui_ImplVulkan_Init(&init, layer->render_pass_)) return Error{"ImGui_ImplVulkan_Init failed"};
  layer->vulkan_backend_ = true;

  bool font_ok = false;
  if (auto st = context.submit_and_wait([&](VkCommandBuffer cmd) { font_ok = ImGui_ImplVulkan_CreateFontsTexture(cmd); });
      !st) {
    return Error{"ImGui font upload: " + st.message()};
  }
  ImGui_ImplVulkan_DestroyFontUploadObjects();
  if (!font_ok) return Error{"ImGui_ImplVulkan_CreateFontsTexture failed"};
  return layer;
}

ImGuiLayer::~ImGuiLayer() {
  if (context_ != nullptr) {
    // The font image, pipeline and vertex buffers may still be read by frames in flight.
    (void)vkQueueWaitIdle(context_->queue());
    if (vulkan_backend_) ImGui_ImplVulkan_Shutdown();
    if (glfw_backend_) ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    destroy_framebuffers();
    if (render_pass_) vkDestroyRenderPass(context_->device(), render_pass_, nullptr);
    if (descriptor_pool_) vkDestroyDescriptorPool(context_->device(), descriptor_pool_, nullptr);
  }
  g_layer_alive = false;
}

void ImGuiLayer::destroy_framebuffers() noexcept {
  for (VkFramebuffer fb : framebuffers_) vkDestroyFramebuffer(context_->device(), fb, nullptr);
  framebuffers_.clear();
}

Status ImGuiLayer::set_targets(const std::vector<VkImageView>& views, VkExtent2D extent, VkFormat format) {
  if (format != format_) {
    return Error{"ImGuiLayer::set_targets: format " + std::to_string(static_cast<int>(format)) +
                 " differs from the render pass format " + std::to_string(static_cast<int>(format_))};
  }
  destroy_framebuffers();
  extent_ = extent;
  for (VkImageView view : views) {
    VkFramebufferCreateInfo fci{};
    fci.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    fci.renderPass = render_pass_;
    fci.attachmentCount = 1;
    fci.pAttachments = &view;
    fci.width = extent.width;
    fci.height = extent.height;
    fci.layers = 1;
    VkFramebuffer fb = VK_NULL_HANDLE;
    GAUSS_VK_TRY(vkCreateFramebuffer(context_->device(), &fci, nullptr, &fb));
    framebuffers_.push_back(fb);
  }
  return Ok{};
}

void ImGuiLayer::begin_frame() {
  if (frame_begun_) ImGui::EndFrame();
  ImGui_ImplVulkan_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  frame_begun_ = true;
}

void ImGuiLayer::record(VkCommandBuffer cmd, std::uint32_t index) {
  if (!frame_begun_) return;
  frame_begun_ = false;
  ImGui::Render();
  if (index >= framebuffers_.size()) return;
  VkRenderPassBeginInfo rbi{};
  rbi.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
  rbi.renderPass = render_pass_;
  rbi.framebuffer = framebuffers_[index];
  rbi.renderArea = {{0, 0}, extent_};
  vkCmdBeginRenderPass(cmd, &rbi, VK_SUBPASS_CONTENTS_INLINE);
  ImGui_ImplVulkan_RenderDrawData(ImGui::GetDrawData(), cmd);
  vkCmdEndRenderPass(cmd);
}

bool ImGuiLayer::wants_mouse() const { return ImGui::GetIO().WantCaptureMouse; }
bool ImGuiLayer::wants_keyboard() const { return ImGui::GetIO().WantCaptureKeyboard; }

}  // namespace gauss::view
