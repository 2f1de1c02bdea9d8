// window_smoke: the desktop viewer's presentation layer end to end on a real window
// (Xvfb in CI: xvfb-run -a -s "-screen 0 1280x800x24" window_smoke [OUT_DIR]).
//
// Opens a 640x480 window, renders frames whose source image is an offscreen colour
// target cleared to a known colour (no compute), draws an ImGui panel with text on top,
// resizes the window to 800x450 half-way and keeps going, and captures one of the last
// frames. Checks on the capture: its size is the resized framebuffer; the letterboxed
// viewport shows the source colour exactly; the pillarbox bars show the clear colour;
// the panel differs from the source and has light text pixels; no validation error.
//
// Then drives vk::Swapchain through the minimised path (0x0 extent: no images, acquire
// says skip; a size again: images, acquire, present), which Xvfb cannot produce through
// the window itself (no window manager to iconify it).
//
// Usage: window_smoke [OUT_DIR] [--mailbox|--immediate]
// Exit code: 0 pass, 1 fail, 77 no display (CTest SKIP_RETURN_CODE).
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <imgui.h>

#include "gauss/engine/image_io.h"
#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_swapchain.h"
#include "glfw.h"
#include "imgui_layer.h"
#include "window.h"

namespace {

using namespace gauss;
namespace fs = std::filesystem;

constexpr std::uint32_t kFrames = 40;
constexpr std::uint32_t kResizeFrame = 16;
constexpr std::uint32_t kScreenshotFrame = kFrames - 4;
constexpr std::uint32_t kFramesInFlight = 2;
// Source: 320x200 (16:10). In 640x480 it is letterboxed (bars top/bottom), in 800x450
// pillarboxed (720x450 at x = 40).
constexpr std::uint32_t kSourceW = 320;
constexpr std::uint32_t kSourceH = 200;
constexpr int kResizedW = 800;
constexpr int kResizedH = 450;
// Exact byte values (k/255) so UNORM conversion has no rounding to argue about.
constexpr std::array<std::uint8_t, 3> kSourceRGB{51, 153, 102};
constexpr std::array<std::uint8_t, 3> kClearRGB{20, 20, 23};
// The panel, in framebuffer pixels.
constexpr int kPanelX = 12, kPanelY = 12, kPanelW = 260, kPanelH = 110;

int failures = 0;
void check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  if (!ok) ++failures;
}

int fail(const std::string& what) {
  std::fprintf(stderr, "window_smoke: %s\n", what.c_str());
  return 1;
}

const std::uint8_t* pixel(const ImageRGBA8& img, std::uint32_t x, std::uint32_t y) {
  return &img.pixels[(std::size_t{y} * img.width + x) * 4];
}

bool near(const std::uint8_t* p, const std::array<std::uint8_t, 3>& rgb, int tolerance) {
  for (int c = 0; c < 3; ++c) {
    if (std::abs(int{p[c]} - int{rgb[c]}) > tolerance) return false;
  }
  return true;
}

// Fraction of pixels in [x0,x1)x[y0,y1) that match `rgb` within `tolerance`.
double fraction_matching(const ImageRGBA8& img, std::uint32_t x0, std::uint32_t y0, std::uint32_t x1, std::uint32_t y1,
                         const std::array<std::uint8_t, 3>& rgb, int tolerance) {
  std::size_t match = 0;
  std::size_t total = 0;
  for (std::uint32_t y = y0; y < y1; ++y) {
    for (std::uint32_t x = x0; x < x1; ++x, ++total) match += near(pixel(img, x, y), rgb, tolerance) ? 1 : 0;
  }
  return total ? static_cast<double>(match) / static_cast<double>(total) : 0.0;
}

struct FrameObjects {
  VkDevice device{VK_NULL_HANDLE};
  VkCommandPool pool{VK_NULL_HANDLE};
  std::array<VkCommandBuffer, kFramesInFlight> cmd{};
  std::array<VkFence, kFramesInFlight> fence{};
  ~FrameObjects() {
    if (device == VK_NULL_HANDLE) return;
    vkDeviceWaitIdle(device);
    for (VkFence f : fence) {
      if (f) vkDestroyFence(device, f, nullptr);
    }
    vkFreeCommandBuffers(device, pool, kFramesInFlight, cmd.data());
  }
};

}  // namespace

int main(int argc, char** argv) {
  fs::path out_dir = "window_smoke_out";
  vk::PresentMode mode = vk::PresentMode::fifo;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--mailbox") {
      mode = vk::PresentMode::mailbox;
    } else if (arg == "--immediate") {
      mode = vk::PresentMode::immediate;
    } else {
      out_dir = arg;
    }
  }
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  const fs::path shot = out_dir / "window_smoke.png";

  view::WindowCreateInfo wi;
  wi.title = "gauss window smoke";
  wi.width = 640;
  wi.height = 480;
  wi.frames_in_flight = kFramesInFlight;
  wi.present_mode = mode;
  for (int c = 0; c < 3; ++c) wi.clear_color[c] = static_cast<float>(kClearRGB[c]) / 255.0f;
  auto window = view::Window::create(wi);
  if (!window) {
    std::fprintf(stderr, "window_smoke: skipped: %s\n", window.message().c_str());
    return 77;
  }

  vk::ContextCreateInfo ci;
  ci.app_name = "window_smoke";
  ci.enable_validation = true;  // the check below needs the layer's verdict
  (*window)->configure_context(ci);
  auto context = vk::Context::create(ci);
  if (!context) return fail(context.message());
  vk::Context& ctx = **context;
  std::printf("device: %s\n", ctx.device_name().c_str());
  check(ctx.validation_enabled(), "validation layer active");
  if (auto st = (*window)->attach(ctx); !st) return fail(st.message());
  const vk::Swapchain* sc = (*window)->swapchain();
  std::printf("swapchain: %ux%u format %d, %u images, %s\n", sc->extent().width, sc->extent().height,
              static_cast<int>(sc->format()), sc->image_count(), vk::present_mode_name(sc->present_mode()));

  auto target = vk::OffscreenTarget::create(ctx, kSourceW, kSourceH, "smoke source");
  if (!target) return fail(target.message());

  view::Viewport vp;
  {
    FrameObjects fo;
    fo.device = ctx.device();
    fo.pool = ctx.command_pool();
    VkCommandBufferAllocateInfo cai{};
    cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cai.commandPool = ctx.command_pool();
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = kFramesInFlight;
    GAUSS_VK_CHECK(vkAllocateCommandBuffers(ctx.device(), &cai, fo.cmd.data()));
    for (auto& f : fo.fence) {
      VkFenceCreateInfo fci{};
      fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
      fci.flags = VK_FENCE_CREATE_SIGNALED_BIT;
      GAUSS_VK_CHECK(vkCreateFence(ctx.device(), &fci, nullptr, &f));
    }

    std::uint32_t presented = 0;
    std::uint32_t skipped = 0;
    bool screenshot_requested = false;
    for (std::uint32_t frame = 0; frame < kFrames; ++frame) {
      const std::uint32_t slot = frame % kFramesInFlight;
      GAUSS_VK_CHECK(vkWaitForFences(ctx.device(), 1, &fo.fence[slot], VK_TRUE, UINT64_MAX));
      (*window)->poll_events();
      if (frame == kResizeFrame) (*window)->set_size(kResizedW, kResizedH);
      auto acquired = (*window)->acquire(slot);
      if (!acquired) return fail(acquired.message());
      if (!*acquired) {
        ++skipped;
        continue;
      }
      // The fence is reset only now that the frame will be submitted (window.h).
      GAUSS_VK_CHECK(vkResetFences(ctx.device(), 1, &fo.fence[slot]));
      VkCommandBuffer cmd = fo.cmd[slot];
      GAUSS_VK_CHECK(vkResetCommandBuffer(cmd, 0));
      VkCommandBufferBeginInfo bi{};
      bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
      bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
      GAUSS_VK_CHECK(vkBeginCommandBuffer(cmd, &bi));

      (*window)->begin_ui();
      ImGui::SetNextWindowPos(ImVec2(kPanelX, kPanelY), ImGuiCond_Always);
      ImGui::SetNextWindowSize(ImVec2(kPanelW, kPanelH), ImGuiCond_Always);
      ImGui::Begin("Smoke panel", nullptr, ImGuiWindowFlags_NoCollapse);
      ImGui::Text("frame %u", frame);
      ImGui::Text("swapchain %ux%u", sc->extent().width, sc->extent().height);
      ImGui::Text("WWWWWWWWWWWWWWWWWWWW");
      ImGui::End();

      // The "scene": the source target cleared to a known colour by a transfer clear.
      vk::Image& color = target->color();
      color.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
      VkClearColorValue clear{};
      for (int c = 0; c < 3; ++c) clear.float32[c] = static_cast<float>(kSourceRGB[c]) / 255.0f;
      clear.float32[3] = 1.0f;
      const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      vkCmdClearColorImage(cmd, color.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &clear, 1, &range);
      color.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);

      if (frame == kScreenshotFrame) {
        (*window)->request_screenshot(shot);
        screenshot_requested = true;
      }
      view::SourceImage src;
      src.image = color.handle();
      src.layout = color.layout();
      src.extent = color.extent();
      src.format = color.format();
      if (auto st = (*window)->record_present(cmd, src); !st) return fail(st.message());
      GAUSS_VK_CHECK(vkEndCommandBuffer(cmd));
      if (auto st = (*window)->submit_and_present(cmd, fo.fence[slot]); !st) return fail(st.message());
      ++presented;
    }
    std::printf("frames presented %u, skipped %u, swapchain generation %llu\n", presented, skipped,
                static_cast<unsigned long long>(sc->generation()));
    check(screenshot_requested, "the screenshot frame was recorded");
    check(sc->generation() >= 1, "the swapchain was recreated after the resize");
    check(sc->extent().width == kResizedW && sc->extent().height == kResizedH,
          "swapchain follows the resize to " + std::to_string(kResizedW) + "x" + std::to_string(kResizedH) + " (is " +
              std::to_string(sc->extent().width) + "x" + std::to_string(sc->extent().height) + ")");
    check(presented + skipped == kFrames && presented >= kFrames - 4, "almost every frame was presented");

    // Minimised path, on a swapchain of our own (the window's is freed first: one
    // swapchain per surface).
    const view::Viewport last = (*window)->last_viewport();
    (*window)->detach();
    vk::SwapchainCreateInfo sci;
    sci.extent = {0, 0};
    sci.frames_in_flight = 1;
    auto own = vk::Swapchain::create(ctx, sci);
    if (!own) return fail(own.message());
    vk::Swapchain& swap = **own;
    check(swap.empty(), "a 0x0 swapchain has no images");
    auto a = swap.acquire(0);
    check(a && a->status == vk::Swapchain::AcquireStatus::skip, "acquire on a 0x0 swapchain says skip");
    if (auto st = swap.recreate({kResizedW, kResizedH}); !st) return fail(st.message());
    check(!swap.empty() && swap.extent().width == kResizedW, "recreate with a size brings images back");
    a = swap.acquire(0);
    check(a && a->status == vk::Swapchain::AcquireStatus::acquired, "acquire after the size came back");
    if (a && a->status == vk::Swapchain::AcquireStatus::acquired) {
      GAUSS_VK_CHECK(vkWaitForFences(ctx.device(), 1, &fo.fence[0], VK_TRUE, UINT64_MAX));
      GAUSS_VK_CHECK(vkResetFences(ctx.device(), 1, &fo.fence[0]));
      VkCommandBuffer cmd = fo.cmd[0];
      GAUSS_VK_CHECK(vkResetCommandBuffer(cmd, 0));
      VkCommandBufferBeginInfo bi{};
      bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
      GAUSS_VK_CHECK(vkBeginCommandBuffer(cmd, &bi));
      VkImageMemoryBarrier2 b{};
      b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
      b.srcStageMask = vk::Swapchain::kAcquireWaitStage;
      b.dstStageMask = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
      b.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
      b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
      b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
      b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
      b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
      b.image = swap.image(a->image_index);
      b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      VkDependencyInfo dep{};
      dep.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
      dep.imageMemoryBarrierCount = 1;
      dep.pImageMemoryBarriers = &b;
      vkCmdPipelineBarrier2(cmd, &dep);
      const VkClearColorValue grey{{0.5f, 0.5f, 0.5f, 1.0f}};
      const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      vkCmdClearColorImage(cmd, b.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &grey, 1, &range);
      b.srcStageMask = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
      b.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
      b.dstStageMask = VK_PIPELINE_STAGE_2_NONE;
      b.dstAccessMask = VK_ACCESS_2_NONE;
      b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
      b.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
      vkCmdPipelineBarrier2(cmd, &dep);
      GAUSS_VK_CHECK(vkEndCommandBuffer(cmd));
      auto presented_own = swap.submit_and_present(cmd, fo.fence[0]);
      check(presented_own.ok(), "submit + present after the size came back");
      GAUSS_VK_CHECK(vkWaitForFences(ctx.device(), 1, &fo.fence[0], VK_TRUE, UINT64_MAX));
    }
    own->reset();
    vp = last;
  }

  *target = vk::OffscreenTarget{};
  context->reset();
  const std::uint64_t validation_errors = vk::process_validation_error_count();
  window->reset();

  auto img = read_png_rgba8(shot);
  if (!img) return fail("screenshot: " + img.message());
  std::printf("screenshot %s: %ux%u, viewport %d,%d %ux%u\n", shot.c_str(), img->width, img->height, vp.x, vp.y,
              vp.width, vp.height);
  check(img->width == kResizedW && img->height == kResizedH, "screenshot has the resized framebuffer's size");
  if (img->width == kResizedW && img->height == kResizedH) {
    check(vp.x == 40 && vp.y == 0 && vp.width == 720 && vp.height == 450, "viewport is the pillarboxed 720x450 at x=40");
    // Viewport outside the panel: exactly the source colour.
    const double scene = fraction_matching(*img, 300, 150, 750, 440, kSourceRGB, 0);
    check(scene == 1.0, "viewport shows the source colour (" + std::to_string(scene * 100.0) + " % exact)");
    // The left bar below the panel (the panel overlaps it), the whole right bar.
    const double bars = fraction_matching(*img, 0, kPanelY + kPanelH + 2, 40, 450, kClearRGB, 0) +
                        fraction_matching(*img, 760, 0, 800, 450, kClearRGB, 0);
    check(bars == 2.0, "pillarbox bars show the clear colour (" + std::to_string(bars * 50.0) + " % exact)");
    const double panel_src = fraction_matching(*img, kPanelX + 4, kPanelY + 4, kPanelX + kPanelW - 4,
                                               kPanelY + kPanelH - 4, kSourceRGB, 8);
    check(panel_src < 0.05, "the panel covers the scene (" + std::to_string(panel_src * 100.0) + " % source colour)");
    std::size_t light = 0;
    for (std::uint32_t y = kPanelY; y < static_cast<std::uint32_t>(kPanelY + kPanelH); ++y) {
      for (std::uint32_t x = kPanelX; x < static_cast<std::uint32_t>(kPanelX + kPanelW); ++x) {
        const std::uint8_t* p = pixel(*img, x, y);
        if (p[0] > 180 && p[1] > 180 && p[2] > 180) ++light;
      }
    }
    check(light > 100, "the panel has text (" + std::to_string(light) + " light pixels)");
  }
  check(validation_errors == 0, "no validation errors (" + std::to_string(validation_errors) + ")");
  std::printf("%s\n", failures == 0 ? "window_smoke: PASS" : "window_smoke: FAIL");
  return failures == 0 ? 0 : 1;
}
