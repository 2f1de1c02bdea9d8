// The two sources of gauss-view: a host's stream and a local scene file.
#include "view_source.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/scene_view.h"
#include "gauss/render/vk_frame_ring.h"

namespace gauss::view {

namespace {

class StreamSource final : public ViewSource {
 public:
  StreamSource(std::unique_ptr<client::ClientRuntime> rt, std::string server, SceneUp up)
      : rt_(std::move(rt)), server_(std::move(server)) {
    up_ = std::move(up);
  }

  Expected<client::DisplayFrameStats> frame(std::span<const Camera> views, const render::FrameHooks& hooks) override {
    auto f = rt_->frame(views, hooks);
    if (f) last_ = *f;
    return f;
  }
  std::vector<client::GpuFrameStats> take_gpu_stats() override { return rt_->take_gpu_stats(); }
  Status wait_frames() override { return rt_->wait_frames(); }
  render::SplatRenderer& renderer() override { return rt_->renderer(); }
  client::ClientRuntime* runtime() noexcept override { return rt_.get(); }
  std::string describe() const override { return "host " + server_; }

  std::optional<msg::SceneView> take_host_view() override {
    const auto taken =
        rt_->try_with_state([](const ClientState& s) -> std::optional<msg::SceneView> { return s.view(); });
    if (!taken || !*taken) return std::nullopt;
    view_ = **taken;
    if (up_.source != UpSource::Option) {
      up_.up = view_up(*view_);
      up_.detail = "the host";
    }
    return view_;
  }
  std::optional<msg::SceneView> host_view() const override { return view_; }

  // From the last frame's figures (the state as its publication step left it), not under
  // the state lock: a running step holds that for its length.
  bool settled(double quiet_s) override {
    const double now = rt_->now();
    const std::uint64_t edits = last_.counters.edits_received, batches = last_.counters.batches;
    if (edits != last_edits_ || batches != last_batches_ || !last_.welcomed) {
      last_edits_ = edits;
      last_batches_ = batches;
      last_change_ = now;
      return false;
    }
    return last_.pending == 0 && last_.desired > 0 && now - last_change_ >= quiet_s;
  }

 private:
  std::unique_ptr<client::ClientRuntime> rt_;
  std::string server_;
  client::DisplayFrameStats last_;  // of the last frame that succeeded
  std::optional<msg::SceneView> view_;  // the host's, once taken
  std::uint64_t last_edits_{~std::uint64_t{0}};
  std::uint64_t last_batches_{0};
  double last_change_{0.0};
};

class LocalSource final : public ViewSource {
 public:
  LocalSource(std::unique_ptr<render::SplatRenderer> r, std::string what, SceneSummary summary, SceneUp up)
      : r_(std::move(r)), what_(std::move(what)), summary_(std::move(summary)) {
    up_ = std::move(up);
  }

  Expected<client::DisplayFrameStats> frame(std::span<const Camera> views, const render::FrameHooks& hooks) override {
    const auto t0 = std::chrono::steady_clock::now();
    client::DisplayFrameStats out;
    out.frame_index = frame_index_;
    auto serial = r_->render_frame(views, {}, hooks);
    if (!serial) return serial.error();
    out.serial = *serial;
    out.resident = r_->occupied_count();
    out.desired = out.resident;
    stats_.submitted(*serial, frame_index_++, static_cast<std::uint32_t>(views.size()));
    stats_.collect(*r_);
    out.render_ms = out.cpu_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }
  std::vector<client::GpuFrameStats> take_gpu_stats() override { return stats_.take(*r_); }
  Status wait_frames() override {
    if (auto st = r_->frames().wait_all(); !st) return st;
    stats_.collect(*r_);
    return Ok{};
  }
  render::SplatRenderer& renderer() override { return *r_; }
  bool settled(double) override { return true; }
  std::string describe() const override { return what_; }
  std::optional<RobustBounds> bounds() const override { return summary_.robust; }
  const SceneSummary* summary() const noexcept override { return &summary_; }

 private:
  std::unique_ptr<render::SplatRenderer> r_;
  std::string what_;
  SceneSummary summary_;
  client::GpuFrameStatsCollector stats_;
  std::uint64_t frame_index_{0};
};

// Windowed views follow the window size: allow up to 2560x1600; headless views the path's size.
std::uint32_t view_max_width(const ViewOptions& o) { return std::max<std::uint32_t>(o.width, o.headless ? 1 : 2560); }
std::uint32_t view_max_height(const ViewOptions& o) { return std::max<std::uint32_t>(o.height, o.headless ? 1 : 1600); }

}  // namespace

Expected<std::unique_ptr<ViewSource>> make_local_source(vk::Context& context, const ViewOptions& o, LoadedScene scene,
                                                        const std::filesystem::path& mesh) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto& gs = scene.scene.cloud.gaussians;
  const std::string name = scene.path.filename().string();
  if (gs.empty()) return Error{scene.path.string() + ": the scene holds no Gaussians"};
  if (gs.size() > 0xFFFFFFFFu)
    return Error{scene.path.string() + ": " + std::to_string(gs.size()) + " Gaussians, more than 2^32 - 1 slots"};
  // A scene the device cannot hold is refused by create, with the numbers.
  auto r = render::SplatRenderer::create(context, {.capacity = static_cast<std::uint32_t>(gs.size()),
                                                   .sh_degree = scene.scene.cloud.sh_degree,
                                                   .max_width = view_max_width(o),
                                                   .max_height = view_max_height(o),
                                                   .frames_in_flight = o.frames_in_flight});
  if (!r) return Error{scene.path.string() + ": " + r.message()};
  if (auto st = (*r)->write_slots(0, gs); !st) return Error{scene.path.string() + ": " + st.message()};
  if (!mesh.empty()) {
    auto m = read_mesh_ply(mesh);
    if (!m) return m.error();
    if (auto st = (*r)->set_mesh(m->mesh); !st) return Error{mesh.string() + ": " + st.message()};
  }
  SceneSummary summary;
  summary.path = scene.path;
  summary.format = scene.scene.report.format;
  summary.gaussians = gs.size();
  summary.skipped = scene.scene.report.dropped.size() + (*r)->rejected_nonfinite();
  summary.sh_degree = scene.scene.cloud.sh_degree;
  summary.robust = scene.robust;
  summary.full = scene.full;
  summary.file_bytes = scene.file_bytes;
  summary.load_s = scene.load_s;
  summary.resident_bytes = std::uint64_t{(*r)->occupied_count()} * (*r)->memory_plan().bytes_per_slot;
  summary.renderer_bytes = (*r)->memory_plan().total_bytes;
  summary.upload_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::string what = "scene " + name + " (" + std::to_string(gs.size()) + " Gaussians, SH " +
                     std::to_string(summary.sh_degree) + ")";
  if (summary.skipped > 0) what += ", " + std::to_string(summary.skipped) + " non-finite Gaussians skipped";
  for (const std::string& note : splat_load_notes(scene.scene.report))
    std::fprintf(stderr, "gauss-view: %s: %s\n", scene.path.string().c_str(), note.c_str());
  if (!scene.up.problem.empty())
    std::fprintf(stderr, "gauss-view: %s; up is %s, %s\n", scene.up.problem.c_str(), up_label(scene.up.up).c_str(),
                 scene.up.detail.c_str());
  return std::unique_ptr<ViewSource>(new LocalSource(std::move(*r), std::move(what), std::move(summary), std::move(scene.up)));
}

Expected<std::unique_ptr<ViewSource>> make_view_source(vk::Context& context, const ViewOptions& o) {
  if (!o.host) {
    auto scene = load_scene_file(o.scene, o.up);
    if (!scene) return scene.error();
    return make_local_source(context, o, std::move(*scene), o.mesh);
  }
  client::ClientRuntimeConfig cfg;  cfg.state.capacity = o.budget;
  cfg.state.access_token = o.token;
  cfg.state.name = o.name;
  cfg.state.publisher.mode = o.mode;
  cfg.frames_in_flight = o.frames_in_flight;
  cfg.publication_thread = o.publication_thread;
  cfg.max_width = view_max_width(o);
  cfg.max_height = view_max_height(o);
  cfg.highlight_query = o.highlight;
  cfg.tint_edits = o.edit_tints;
  auto rt = client::ClientRuntime::create(context, cfg);
  if (!rt) return rt.error();
  net::NetClientConfig net;
  net.server = *o.host;
  if (auto st = (*rt)->connect(net); !st) return st.error();
  SceneUp up;
  up.up = glm::dvec3(0.0, 1.0, 0.0);
  up.detail = "+y until the host announces its scene's up";
  if (o.up) {
    up.up = *o.up;
    up.source = UpSource::Option;
    up.detail = "--up " + up_label(*o.up);
  }
  return std::unique_ptr<ViewSource>(new StreamSource(std::move(*rt), net::to_string(*o.host), std::move(up)));
}

}  // namespace gauss::view
