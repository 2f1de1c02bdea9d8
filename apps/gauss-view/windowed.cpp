// gauss-view windowed: the window, its Vulkan context and the frame loop (camera, panels,
// 1 or 2 views, present, dropped files, screenshots). The presentation layer is window.h,
// the panels panels.h.
#include "windowed.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "default_view.h"
#include "fly_camera.h"
#include "orbit_control.h"
#include "gauss/engine/camera_io.h"
#include "gauss/engine/numbered_file.h"
#include "gauss/engine/scene_load.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_image.h"
#include "panels.h"
#include "view_source.h"
#include "window.h"

namespace gauss::view {
namespace {

// The renderer's largest view (make_view_source allows 2560x1600 for a window); a larger
// framebuffer gets a view scaled down to fit, which the present blit scales up again.
constexpr std::uint32_t kMaxViewW = 2560, kMaxViewH = 1600;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The view size for a framebuffer: the same aspect, within the renderer's maximum.
VkExtent2D view_extent(VkExtent2D fb) {
  const double scale = std::min({1.0, static_cast<double>(kMaxViewW) / fb.width, static_cast<double>(kMaxViewH) / fb.height});
  return {std::max(1u, static_cast<std::uint32_t>(fb.width * scale)),
          std::max(1u, static_cast<std::uint32_t>(fb.height * scale))};
}

class FrameLoop {
 public:
  // `source` is replaced when a dropped file opens (the caller's pointer, so that its
  // teardown order holds for whichever source is shown last).
  FrameLoop(const ViewOptions& opts, vk::Context& context, Window& window, std::unique_ptr<ViewSource>& source)
      : opts_(opts), context_(context), window_(window), source_(source), panels_(opts, *source),
        slot_serial_(opts.frames_in_flight, 0), renderer_(&source->renderer()) {}

  // Runs until the window closes or --exit-after frames. Returns the exit status.
  int run();

 private:
  Status start_pose();
  // The default camera again (F, 1 / 2 / 3, the view panel): a local scene's framing from
  // `preset`'s side for the window's current size; a stream's box once it is known (a
  // stream has one view of it).
  void reframe(ViewPreset preset = ViewPreset::Front);
  // A stream: frames the view its host announced once it is known (stream_framing), from
  // stream_preset_'s side; the host's up becomes the camera's the first time (unless --up).
  void frame_stream();
  // Waits until frame slot `slot`'s previous frame finished (its acquire semaphore and the
  // UI's buffers are free again; vk_swapchain.h step 1).
  Status wait_slot(std::uint32_t& out_slot);
  Status record_present(VkCommandBuffer cmd, std::uint32_t views);
  // Files dropped on the window: the first starts a load off this thread (SceneLoadJob); a
  // drop during a load waits for it, and that load's result is then discarded.
  void take_drops(double now_s);
  void start_load(const std::filesystem::path& path, double now_s);
  // A load ended: its scene replaces the source, framed as --scene is at start-up; or its
  // error is shown and printed, the current scene untouched. Errors: the old source's
  // frames could not be waited for (fatal, as any frame error).
  Status finish_load(double now_s);
  // The P key: a new gauss-view-NNNN.png in --screenshot-dir, written by the next frame.
  void key_screenshot(double now_s);
  // After a frame: a screenshot's outcome. Errors: the --screenshot file was not written.
  Status report_screenshot(double now_s);

  const ViewOptions& opts_;
  vk::Context& context_;
  Window& window_;
  std::unique_ptr<ViewSource>& source_;
  Panels panels_;
  FlyCamera camera_;
  // Orbit mode drives camera_'s pose about a pivot ahead of it (orbit_control.h).
  OrbitControl orbit_;
  bool orbit_mode_{false};
  glm::dvec3 framed_centre_{0.0};  // the last framing's target: where entering orbit aims
  bool auto_frame_{false};  // a stream: frame the host's view once it is known, until the user moves
  ViewPreset stream_preset_{ViewPreset::Front};
  bool stream_up_taken_{false};  // the host's up has been given to the camera
  std::vector<std::uint64_t> slot_serial_;  // renderer serial that last used each slot
  render::SplatRenderer* renderer_;
  std::unique_ptr<SceneLoadJob> load_;
  std::optional<std::filesystem::path> next_drop_;  // dropped during load_
  bool option_shot_written_{false};  // --screenshot
};

Status FrameLoop::start_pose() {
  // The scene's up first, so that a --camera's roll is dropped toward it.
  camera_.set_up(source_->up().up);
  if (!opts_.camera.empty()) {
    auto c = read_camera_json(opts_.camera);
    if (!c) return c.error();
    camera_.set_from_camera(*c);
    return Ok{};
  }
  reframe(opts_.view);
  return Ok{};
}

void FrameLoop::reframe(ViewPreset preset) {
  if (source_->runtime() != nullptr) {
    auto_frame_ = true;
    stream_preset_ = preset;
    return;
  }
  // The mono view's size and focal length (run() keeps the pixel scale in stereo).
  const VkExtent2D ve = view_extent(window_.framebuffer_extent());
  if (auto fr = default_framing(*source_, camera_.up(), opts_.fov_deg, ve.width, ve.height, preset)) {
    camera_.frame(*fr);
    orbit_.frame(*fr);
    framed_centre_ = fr->target;
  }
}

void FrameLoop::frame_stream() {
  // Tried every frame until the view is known: never waits for a publication step.
  const auto view = source_->take_host_view();
  if (!view) return;
  if (!stream_up_taken_) {
    camera_.set_up(source_->up().up);
    stream_up_taken_ = true;
  }
  const VkExtent2D ve = view_extent(window_.framebuffer_extent());
  const Framing fr = stream_framing(*view, camera_.up(), opts_.fov_deg, ve.width, ve.height, stream_preset_);
  camera_.frame(fr);
  orbit_.frame(fr);
  framed_centre_ = fr.target;
  auto_frame_ = false;
}

Status FrameLoop::wait_slot(std::uint32_t& out_slot) {
  render::SplatRenderer* r = &source_->renderer();
  if (r != renderer_) {
    // The runtime replaced its renderer (another SH degree): the old ring's serials mean
    // nothing to the new one, so wait for everything once.
    if (auto st = source_->wait_frames(); !st) return st;
    std::fill(slot_serial_.begin(), slot_serial_.end(), 0);
    renderer_ = r;
  }
  // The renderer's ring gives this frame slot serial % N; the swapchain and the UI use
  // the same slot.
  out_slot = static_cast<std::uint32_t>(r->frames().recording_serial() % slot_serial_.size());
  if (slot_serial_[out_slot] != 0) return r->frames().wait(slot_serial_[out_slot]);
  return Ok{};
}

Status FrameLoop::record_present(VkCommandBuffer cmd, std::uint32_t views) {
  // The blend pass leaves each view's colour image in TRANSFER_DST_OPTIMAL after a
  // buffer->image copy: make that copy visible to the present's transfer read.
  SourceImage src[Window::kMaxSources];
  render::SplatRenderer& r = source_->renderer();
  for (std::uint32_t v = 0; v < views; ++v) {
    vk::Image& img = r.target(v).color();
    img.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                   VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    src[v].image = img.handle();
    src[v].layout = img.layout();
    src[v].extent = img.extent();
    src[v].format = img.format();
    src[v].written_stage = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
    src[v].written_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  }
  return window_.record_present(cmd, std::span<const SourceImage>(src, views));
}

void FrameLoop::take_drops(double now_s) {
  const std::vector<std::filesystem::path> dropped = window_.take_dropped();
  if (dropped.empty()) return;
  if (dropped.size() > 1)
    panels_.show_notice(std::to_string(dropped.size()) + " files dropped: opening the first", now_s);
  panels_.clear_error();
  if (load_ != nullptr) {
    next_drop_ = dropped.front();
    return;
  }
  start_load(dropped.front(), now_s);
}

void FrameLoop::start_load(const std::filesystem::path& path, double now_s) {
  std::fprintf(stderr, "gauss-view: opening %s\n", path.string().c_str());
  load_ = std::make_unique<SceneLoadJob>(path, opts_.up);
  panels_.set_loading(load_.get(), now_s);
}

Status FrameLoop::finish_load(double now_s) {
  const std::unique_ptr<SceneLoadJob> job = std::move(load_);
  panels_.set_loading(nullptr, now_s);
  if (next_drop_) {
    start_load(*std::exchange(next_drop_, std::nullopt), now_s);
    return Ok{};
  }
  auto loaded = job->take();
  // The renderer is made while the old one still draws: a failure leaves the old untouched.
  auto made = loaded ? make_local_source(context_, opts_, std::move(*loaded)) : Expected<std::unique_ptr<ViewSource>>(loaded.error());
  if (!made) {
    std::fprintf(stderr, "gauss-view: could not open %s: %s (the scene shown is unchanged)\n",
                 job->path().string().c_str(), made.message().c_str());
    panels_.show_error(made.message());
    return Ok{};
  }
  // The old renderer's frames (and the presents that read its images) finish before it goes.
  if (auto st = source_->wait_frames(); !st) return st;
  source_ = std::move(*made);
  std::fill(slot_serial_.begin(), slot_serial_.end(), 0);
  renderer_ = &source_->renderer();
  panels_.set_source(*source_);
  window_.set_title("gauss-view: " + job->path().filename().string());
  std::fprintf(stderr, "gauss-view: opened %s in %.2f s\n", source_->describe().c_str(), source_->summary()->load_s);
  // As at start-up (start_pose without --camera): the scene's up, then its default framing.
  auto_frame_ = false;
  camera_.set_up(source_->up().up);
  reframe(opts_.view);
  const glm::dvec3 eye = camera_.pose().position;
  std::fprintf(stderr, "gauss-view: framed from %.4g %.4g %.4g looking at %.4g %.4g %.4g\n", eye.x, eye.y, eye.z,
               framed_centre_.x, framed_centre_.y, framed_centre_.z);
  return Ok{};
}

void FrameLoop::key_screenshot(double now_s) {
  auto path = create_numbered_file(opts_.screenshot_dir, "gauss-view", ".png");
  if (!path) {
    std::fprintf(stderr, "gauss-view: no screenshot: %s\n", path.message().c_str());
    panels_.show_notice("no screenshot: " + path.message(), now_s);
    return;
  }
  window_.request_screenshot(*path);
}

Status FrameLoop::report_screenshot(double now_s) {
  auto shot = window_.take_screenshot_result();
  if (!shot) return Ok{};
  const bool option = !opts_.screenshot.empty() && shot->path == opts_.screenshot;
  if (!shot->written) {
    std::fprintf(stderr, "gauss-view: screenshot not written: %s\n", shot->written.message().c_str());
    if (option) return shot->written.error();
    std::error_code ec;
    std::filesystem::remove(shot->path, ec);  // the empty file create_numbered_file made
    panels_.show_notice("screenshot not written: " + shot->written.message(), now_s);
    return Ok{};
  }
  const std::string where = std::filesystem::absolute(shot->path).string();
  std::fprintf(stderr, "gauss-view: wrote %s\n", where.c_str());
  if (option) option_shot_written_ = true;
  else panels_.show_notice("screenshot " + where, now_s);
  return Ok{};
}

int FrameLoop::run() {
  if (auto st = start_pose(); !st) {
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
    return 1;
  }
  const auto t0 = std::chrono::steady_clock::now();
  double last_t = 0.0;
  std::uint64_t presented = 0;
  // The frames --exit-after and --screenshot-after count: with --drop, those after its load
  // ended (options.h), so that a shot shows the outcome, however long the load took.
  std::uint64_t counted = 0;
  bool drop_injected = opts_.drop.empty(), drop_waiting = !opts_.drop.empty(), press_injected = opts_.press_key == 0;
  bool screenshot_requested = false;
  while (!window_.should_close()) {
    // Scripted input goes through the window as a person's would (window.h press / drop).
    if (!press_injected && presented >= opts_.press_after) {
      window_.press(opts_.press_key);
      press_injected = true;
    }
    if (!drop_injected && presented >= opts_.drop_after) {
      const std::string dropped = opts_.drop.string();
      window_.drop(std::span<const std::string>(&dropped, 1));
      drop_injected = true;
    }
    window_.poll_events();
    if (window_.should_close()) break;
    if (window_.minimised()) {
      window_.wait_events(0.1);
      continue;
    }
    const double t = seconds_since(t0);
    const double dt = presented == 0 ? 0.0 : t - last_t;
    take_drops(t);
    if (load_ != nullptr && load_->ready()) {
      if (auto st = finish_load(t); !st) {
        std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
        return 1;
      }
    }
    // The drop has been handled once no load is left in flight for it (also when it never
    // started one), so a run never waits for a load that is not coming.
    if (drop_waiting && drop_injected && load_ == nullptr) drop_waiting = false;
    const InputState& in = window_.input();
    if (in.screenshot) key_screenshot(t);
    if (const auto orbit = panels_.take_mode_request(); in.toggle_orbit || orbit) {
      // The view stays where it is; only what the mouse does changes.
      orbit_mode_ = orbit.value_or(!orbit_mode_);
      if (orbit_mode_) orbit_.aim(camera_, framed_centre_);
    }
    // In orbit mode the wheel zooms toward the pivot instead of setting the fly speed.
    InputState fly_in = in;
    if (orbit_mode_) fly_in.scroll = 0.0;
    bool moved = camera_.update(fly_in, dt);
    if (orbit_mode_) {
      const double focal = focal_from_hfov(opts_.fov_deg, view_extent(window_.framebuffer_extent()).width);
      moved = orbit_.update(camera_, in, focal) || moved;
    }
    if (moved) auto_frame_ = false;
    if (const auto asked = panels_.take_view_request(); in.view || asked) reframe(asked ? *asked : *in.view);
    if (auto up = panels_.take_up_request()) {
      // A new up turns the default view with it: frame again, upright for it.
      camera_.set_up(*up);
      reframe();
    }
    if (auto_frame_) frame_stream();

    std::uint32_t slot = 0;
    if (auto st = wait_slot(slot); !st) {
      std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
      return 1;
    }
    auto acquired = window_.acquire(slot);
    if (!acquired) {
      std::fprintf(stderr, "gauss-view: %s\n", acquired.message().c_str());
      return 1;
    }
    if (!*acquired) {
      window_.wait_events(0.01);  // nothing to draw into yet (a resize in progress)
      continue;
    }
    const VkExtent2D fb = window_.framebuffer_extent();
    if (!opts_.no_ui) {
      window_.begin_ui();
      panels_.draw(camera_, orbit_mode_, fb.width, fb.height, t);
    }
    if (!opts_.screenshot.empty() && !screenshot_requested && !drop_waiting && counted >= opts_.screenshot_after) {
      window_.request_screenshot(opts_.screenshot);
      screenshot_requested = true;
    }

    // One view, or two eyes side by side (each half the window, the mono view's focal
    // length so that the preview keeps the pixel scale).
    const ViewSettings& vs = panels_.settings();
    const std::uint32_t views = vs.stereo ? 2 : 1;
    const VkExtent2D ve = view_extent({std::max(views, fb.width / views), fb.height});
    const double focal = focal_from_hfov(opts_.fov_deg, view_extent(fb).width);
    const Camera centre = camera_.camera(ve.width, ve.height, focal);
    Camera cams[2] = {centre, centre};
    if (views == 2) {
      cams[0] = render::stereo_eye_camera(centre, vs.ipd, render::Eye::Left);
      cams[1] = render::stereo_eye_camera(centre, vs.ipd, render::Eye::Right);
    }
    render::FrameHooks hooks;
    hooks.record_after = [&](VkCommandBuffer cmd) { return record_present(cmd, views); };
    hooks.submit = [&](VkCommandBuffer cmd, VkFence fence) { return window_.submit_and_present(cmd, fence); };
    auto fs = source_->frame(std::span<const Camera>(cams, views), hooks);
    if (!fs) {
      std::fprintf(stderr, "gauss-view: frame %llu: %s\n", static_cast<unsigned long long>(presented),
                   fs.message().c_str());
      return 1;
    }
    slot_serial_[slot] = fs->serial;
    ++presented;
    if (!drop_waiting) ++counted;
    if (auto st = report_screenshot(t); !st) return 1;
    panels_.add_frame(*fs, dt * 1000.0);
    for (const auto& g : source_->take_gpu_stats()) panels_.add_gpu(g);
    last_t = t;
    if (opts_.exit_after > 0 && counted >= opts_.exit_after) break;
  }
  if (auto st = source_->wait_frames(); !st) {
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
    return 1;
  }
  std::fprintf(stderr, "gauss-view: %llu frames\n", static_cast<unsigned long long>(presented));
  if (!opts_.screenshot.empty() && !option_shot_written_) {
    std::fprintf(stderr, "gauss-view: no screenshot written: the window closed after %llu frames (--screenshot-after %u)\n",
                 static_cast<unsigned long long>(presented), opts_.screenshot_after);
    return 1;
  }
  return 0;
}

}  // namespace

int run_windowed(const ViewOptions& opts) {
  WindowCreateInfo wci;
  wci.title = "gauss-view: " + (opts.host ? net::to_string(*opts.host) : opts.scene.filename().string());
  wci.width = static_cast<int>(opts.width);
  wci.height = static_cast<int>(opts.height);
  wci.frames_in_flight = opts.frames_in_flight;
  auto window = Window::create(wci);
  if (!window) {
    std::fprintf(stderr, "gauss-view: %s\n", window.message().c_str());
    return 1;
  }
  vk::ContextCreateInfo ci;
  ci.app_name = "gauss-view";
  ci.device_override = opts.device;
  (*window)->configure_context(ci);
  auto context = vk::Context::create(ci);
  if (!context) {
    std::fprintf(stderr, "gauss-view: %s\n", context.message().c_str());
    return 1;
  }
  int rc = 0;
  if (auto st = (*window)->attach(**context); !st) {
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
    rc = 1;
  } else {
    auto source = make_view_source(**context, opts);
    if (!source) {
      std::fprintf(stderr, "gauss-view: %s\n", source.message().c_str());
      rc = 1;
    } else {
      std::fprintf(stderr, "gauss-view: %s, window %ux%u\n", (*source)->describe().c_str(), opts.width, opts.height);
      rc = FrameLoop(opts, **context, **window, *source).run();
      // Teardown (window.h): frames finished, then the window's swapchain and UI, the
      // source's renderer, the context, and GLFW last.
      (void)(*source)->wait_frames();
      (*window)->detach();
      source->reset();
    }
  }
  (*window)->detach();
  const std::uint64_t validation_errors = (*context)->validation_error_count();
  context->reset();
  window->reset();
  if (validation_errors > 0) {
    std::fprintf(stderr, "gauss-view: %llu Vulkan validation errors\n", static_cast<unsigned long long>(validation_errors));
    return rc == 0 ? 1 : rc;
  }
  return rc;
}

}  // namespace gauss::view
