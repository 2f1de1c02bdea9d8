// gauss-view --headless: a camera path in, frames and per-frame figures out.
#include "headless.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <array>
#include <map>
#include <thread>

#include <nlohmann/json.hpp>

#include "gauss/client/camera_path.h"
#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/render/splat_math.h"
#include "default_view.h"
#include "status_line.h"
#include "percentile.h"
#include "headless_report.h"

namespace gauss::view {

namespace {

using apps::percentile;
using nlohmann::json;

client::CameraIntrinsics default_intrinsics(const ViewOptions& o) {
  client::CameraIntrinsics in;
  in.width = o.width;
  in.height = o.height;
  in.fx = in.fy = focal_from_hfov(o.fov_deg, o.width);
  in.cx = 0.5 * o.width;
  in.cy = 0.5 * o.height;
  return in;
}

// Frames a scene's default camera is rendered for without --path: the frames in flight
// cycle once and the last is read back after the others.
constexpr std::uint32_t kDefaultCameraFrames = 3;
// A frame's period while the stream settles with nothing to show (about a 90 Hz display).
constexpr std::chrono::milliseconds kSettleFramePeriod{11};

// The default camera held still: keyframes at t = 0 and t = kDefaultCameraFrames - 1 at
// 1 fps, so frame k is at t = k exactly and the path has kDefaultCameraFrames frames.
client::CameraPath default_camera_path(const Framing& fr, const client::CameraIntrinsics& in) {
  client::CameraPath p;
  p.intrinsics = in;
  p.fps = 1.0;
  const client::PathKeyframe k{.t = 0.0, .eye = fr.eye, .look_at = fr.target, .up = fr.up};
  p.keyframes = {k, k};
  p.keyframes[1].t = kDefaultCameraFrames - 1;
  return p;
}

json vec_json(const glm::dvec3& v) { return json::array({v.x, v.y, v.z}); }

// The view a host announces for its scene (SceneInfo::view), once its SceneInfo has come (the
// source takes the host's up with it); an error when the host refuses the client or sends
// nothing within `limit_s`.
Expected<msg::SceneView> wait_for_host_view(ViewSource& src, client::ClientRuntime& rt, const std::string& host,
                                            double limit_s) {
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    if (auto view = src.take_host_view()) return *view;
    const client::ConnectionInfo conn = rt.connection();
    if (conn.status == net::ClientStatus::Refused) return Error{conn.counters.last_rejection};
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > limit_s) {
      const std::string within = "no scene from " + host + " within " +
                                 std::to_string(static_cast<int>(std::ceil(limit_s))) + " s (--settle-timeout)";
      // A host that keeps turning the client away for now (full) is there, just without room.
      if (conn.counters.turned_away > 0)
        return Error{within + ": " + conn.counters.last_rejection + " (" + std::to_string(conn.counters.turned_away) +
                     " attempts)"};
      return Error{within + ", so there is nothing to frame; is gauss-host running there? (--path flies a camera "
                   "path regardless)"};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

json epoch_json(const std::optional<Epoch>& e) { return e ? json(to_underlying(*e)) : json(nullptr); }

// The pass times in kGpuPasses order.
std::array<double, std::size(kGpuPasses)> pass_values(const render::SplatPassTimings& t) {
  return {t.mesh_ms, t.preprocess_ms, t.compact_ms, t.depth_sort_ms, t.emit_ms, t.tile_sort_ms, t.ranges_ms, t.blend_ms};
}

json passes_json(const render::SplatPassTimings& t) {
  json out{{"total", t.total_ms}};
  const auto values = pass_values(t);
  for (std::size_t i = 0; i < values.size(); ++i) out[kGpuPasses[i]] = values[i];
  return out;
}

// Frames whose CPU figures are known and whose GPU figures are not yet.
class FrameLog {
 public:
  explicit FrameLog(std::ofstream& out) : out_(out) {}
  void cpu(std::uint64_t frame, json line) { pending_[frame] = std::move(line); }
  void gpu(const client::GpuFrameStats& g) {
    auto it = pending_.find(g.frame_index);
    if (it == pending_.end()) return;
    json& line = it->second;
    line["gpu_ms"] = g.total_ms;
    json views = json::array();
    for (std::uint32_t v = 0; v < g.views; ++v)
      views.push_back(json{{"passes_ms", passes_json(g.view[v].gpu)},
                           {"visible", g.view[v].visible},
                           {"pairs", g.view[v].pairs},
                           {"pair_overflow", g.view[v].pair_overflow}});
    line["views"] = std::move(views);
    gpu_ms_.push_back(g.total_ms);
    const auto passes = pass_values(g.view[0].gpu);
    for (std::size_t i = 0; i < passes.size(); ++i) pass_ms_[i].push_back(passes[i]);
    flush_ready();
  }
  void flush_all() {
    for (auto& [frame, line] : pending_) out_ << line.dump() << '\n';
    pending_.clear();
  }
  std::vector<double> gpu_ms_;
  std::array<std::vector<double>, std::size(kGpuPasses)> pass_ms_;  // view 0, in kGpuPasses order

 private:
  void flush_ready() {
    // Lines go out in frame order, each once its GPU figures are in.
    while (!pending_.empty() && pending_.begin()->second.contains("gpu_ms")) {
      out_ << pending_.begin()->second.dump() << '\n';
      pending_.erase(pending_.begin());
    }
  }
  std::ofstream& out_;
  std::map<std::uint64_t, json> pending_;
};

// The active query as the client holds it now: its targets, how many of their Gaussians
// are resident (from `per_object`, ClientRuntime::resident_per_object), their members on
// the host (the latest object table) and the share of M.
json query_state(client::ClientRuntime& rt, double rho, const std::map<std::int32_t, std::uint32_t>& per_object) {
  struct Q {
    std::vector<ObjectId> targets;
    std::uint64_t on_host_at_resolution;
    std::uint64_t members;
  };
  const Q q = rt.with_state([](const ClientState& st) {
    std::uint64_t members = 0;
    for (ObjectId o : st.query_targets())
      if (auto it = st.objects().find(to_underlying(o)); it != st.objects().end()) members += it->second.member_count;
    return Q{st.query_targets(), st.query_target_gaussians(), members};
  });
  std::uint64_t on_targets = 0;
  json targets = json::array();
  for (ObjectId o : q.targets) {
    targets.push_back(to_underlying(o));
    if (auto it = per_object.find(to_underlying(o)); it != per_object.end()) on_targets += it->second;
  }
  return json{{"active", !q.targets.empty()},
              {"targets", std::move(targets)},
              {"rho", rho >= 0.0 ? json(rho) : json(nullptr)},
              {"target_resident", on_targets},
              {"target_gaussians_on_host", q.on_host_at_resolution},
              {"target_members", q.members},
              {"share", rt.capacity() > 0 ? double(on_targets) / rt.capacity() : 0.0}};
}

Status write_views(ViewSource& src, const std::filesystem::path& base, std::uint32_t views) {
  for (std::uint32_t v = 0; v < views; ++v) {
    auto img = src.renderer().read_image(v);
    if (!img) return img.error();
    std::filesystem::path p = base;
    p += v == 0 ? ".png" : "_right.png";
    if (auto st = write_png(p, *img); !st) return st;
  }
  return Ok{};
}

}  // namespace

int run_headless(const ViewOptions& opts_in, vk::Context& context) {
  ViewOptions opts = opts_in;
  // A path file, or (a local scene without one) the scene's default camera, made once the
  // scene is loaded.
  std::optional<client::CameraPath> path;
  if (!opts.path.empty()) {
    auto read = client::read_camera_path(opts.path);
    if (!read) {
      std::fprintf(stderr, "gauss-view: %s\n", read.message().c_str());
      return 1;
    }
    path = std::move(*read);
  }
  const client::CameraIntrinsics in =
      path && path->intrinsics ? *path->intrinsics : default_intrinsics(opts);
  opts.width = in.width;
  opts.height = in.height;
  auto source = make_view_source(context, opts);
  if (!source) {
    std::fprintf(stderr, "gauss-view: %s\n", source.message().c_str());
    return 1;
  }
  ViewSource& src = **source;
  client::ClientRuntime* rt = src.runtime();
  json default_camera = nullptr;
  if (!path && rt) {
    // A stream has no bounds until the host describes its scene: the camera is the first
    // view of the host's announced view (stream_framing), held still.
    auto view = wait_for_host_view(src, *rt, src.describe(), opts.settle_timeout_s);
    if (!view) {
      std::fprintf(stderr, "gauss-view: %s\n", view.message().c_str());
      return 1;
    }
    const Framing framing = stream_framing(*view, src.up().up, opts.fov_deg, in.width, in.height, opts.view);
    path = default_camera_path(framing, in);
    default_camera = json{{"bounds", {{"lo", vec_json(glm::dvec3(view->subject_min))}, {"hi", vec_json(glm::dvec3(view->subject_max))}}},
                          {"host_view", true},
                          {"inside", (view->flags & msg::kViewInside) != 0},
                          {"up", vec_json(framing.up)},
                          {"up_from", src.up().detail},
                          {"eye", vec_json(framing.eye)},
                          {"target", vec_json(framing.target)}};
  } else if (!path) {
    // A local scene always has bounds.
    const auto framing = default_framing(src, src.up().up, opts.fov_deg, in.width, in.height, opts.view);
    if (!framing) {
      std::fprintf(stderr, "gauss-view: %s has no bounds to frame; give --path\n", src.describe().c_str());
      return 1;
    }
    path = default_camera_path(*framing, in);
    const RobustBounds box = *src.bounds();
    default_camera = json{{"bounds", {{"lo", vec_json(box.lo)}, {"hi", vec_json(box.hi)}}},
                          {"opacity_weighted", box.opacity_weighted},
                          {"finite_centres", box.finite},
                          {"up", vec_json(framing->up)},
                          {"up_from", src.up().detail},
                          {"eye", vec_json(framing->eye)},
                          {"target", vec_json(framing->target)}};
  }

  std::error_code ec;
  std::filesystem::create_directories(opts.out / "frames", ec);
  if (ec) {
    std::fprintf(stderr, "gauss-view: cannot create %s: %s\n", (opts.out / "frames").string().c_str(),
                 ec.message().c_str());
    return 1;
  }
  std::ofstream jsonl(opts.out / "frames.jsonl");
  if (!jsonl) {
    std::fprintf(stderr, "gauss-view: cannot write %s\n", (opts.out / "frames.jsonl").string().c_str());
    return 1;
  }
  FrameLog log(jsonl);
  char flown[512];
  if (opts.path.empty() && rt)
    std::snprintf(flown, sizeof flown, "the host's view of its scene (up %s, from %s), held",
                  up_label(src.up().up).c_str(), src.up().detail.c_str());
  else if (opts.path.empty())
    std::snprintf(flown, sizeof flown, "its default camera (up %s, %s) for %u frames", up_label(src.up().up).c_str(),
                  src.up().detail.c_str(), kDefaultCameraFrames);
  else
    std::snprintf(flown, sizeof flown, "path %s (%.1f s at %.0f fps)", opts.path.string().c_str(), path->duration(),
                  path->fps);
  std::fprintf(stderr, "gauss-view: %s, %s, %ux%u%s, out %s\n", src.describe().c_str(), flown, in.width, in.height,
               opts.stereo_ipd > 0.0 ? " stereo" : "", opts.out.string().c_str());
  const std::uint64_t path_frames = static_cast<std::uint64_t>(std::floor(path->duration() * path->fps)) + 1;
  const double settle_limit = path->settle_s > 0.0 ? path->settle_s : opts.settle_timeout_s;
  std::size_t next_event = 0;
  double query_rho = -1.0;  // < 0: no query active
  std::map<std::uint32_t, double> queries_sent;  // query id -> client time it was sent
  json queries_at_clear = json::array();
  std::vector<double> cpu_ms;
  apps::StatusLine status;
  const auto wall0 = std::chrono::steady_clock::now();
  std::optional<std::chrono::steady_clock::time_point> settle_start;
  bool settled = false;
  Camera camera{};
  std::uint64_t frame = 0, rendered = 0;
  std::uint32_t views = opts.stereo_ipd > 0.0 ? 2 : 1;
  // The path's clock starts with the stream: until the host has welcomed the client and its
  // first epoch is published, frames look from the path's start and are not path frames
  // (else a path flown while connecting would show nothing). A stream that does not start
  // within the settle limit (no host there) is reported, and the path is flown anyway.
  bool streaming = rt == nullptr;
  std::uint64_t path_frame = 0, preroll_frames = 0;
  for (; frame < opts.max_frames; ++frame) {
    bool connected = false;  // welcomed by the host at this frame (a local scene: never)
    if (rt) {
      // A refusal is final (the network service stopped): no stream will ever settle. (A host
      // that is full for now leaves the client Connecting, retrying.)
      const client::ConnectionInfo conn = rt->connection();
      connected = conn.status == net::ClientStatus::Connected;
      if (conn.status == net::ClientStatus::Refused) {
        status.done({});
        std::fprintf(stderr, "gauss-view: %s\n", conn.counters.last_rejection.c_str());
        return 1;
      }
    }
    if (!streaming && std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count() > settle_limit) {
      status.done({});
      std::fprintf(stderr, "gauss-view: no stream from %s after %.0f s; flying the path anyway\n",
                   src.describe().c_str(), settle_limit);
      streaming = true;
    }
    const double t = std::min(static_cast<double>(path_frame) / path->fps, path->duration());
    camera = path->camera_at(t, in);
    // Events due by this frame's time (each fires once).
    while (streaming && path_frame < path_frames && next_event < path->events.size() && path->events[next_event].t <= t) {
      const client::PathEvent& e = path->events[next_event++];
      if (!rt) continue;  // a local scene has no stream to query
      switch (e.kind) {
        case client::PathEventKind::ClassQuery:
        case client::PathEventKind::InstanceQuery: {
          msg::Query q;
          q.kind = e.kind == client::PathEventKind::ClassQuery ? msg::QueryKind::ClassText : msg::QueryKind::Instance;
          q.text = e.text;
          q.instance = e.instance;
          q.rho = e.rho;
          queries_sent[rt->send_query(q)] = rt->now();
          query_rho = e.rho;
          break;
        }
        case client::PathEventKind::Clear:
          // What the query held just before it is cleared (the report's "while active").
          if (query_rho >= 0.0) queries_at_clear.push_back(query_state(*rt, query_rho, rt->resident_per_object()));
          rt->clear_query();
          query_rho = -1.0;
          break;
        case client::PathEventKind::Mode:
          rt->set_publish_mode(e.mode);
          break;
      }
    }
    Camera cams[2] = {camera, camera};
    if (views == 2) {
      cams[0] = render::stereo_eye_camera(camera, opts.stereo_ipd, render::Eye::Left);
      cams[1] = render::stereo_eye_camera(camera, opts.stereo_ipd, render::Eye::Right);
    }
    auto fs = src.frame(std::span<const Camera>(cams, views));
    if (!fs) {
      std::fprintf(stderr, "gauss-view: frame %llu: %s\n", static_cast<unsigned long long>(frame), fs.message().c_str());
      return 1;
    }
    ++rendered;
    cpu_ms.push_back(fs->cpu_ms);
    log.cpu(frame, json{{"frame", frame},
                        {"t", t},
                        {"on_path", streaming},
                        {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count()},
                        {"connected", connected},
                        {"cpu_ms", fs->cpu_ms},
                        {"publish_ms", fs->publish_ms},
                        {"upload_ms", fs->upload_ms},
                        {"render_ms", fs->render_ms},
                        {"resident", fs->resident},
                        {"desired", fs->desired},
                        {"pending", fs->pending},
                        {"published_epoch", epoch_json(fs->published_epoch)},
                        {"surface_epoch", epoch_json(fs->surface_epoch)},
                        {"edits_published", fs->publish.edits()},
                        {"slot_writes", fs->publish.slot_writes()},
                        {"upload_ranges", fs->ranges},
                        {"allowance", fs->publish.allowance},
                        {"chunks_changed", fs->uploaded.chunks_changed}});
    for (const auto& g : src.take_gpu_stats()) log.gpu(g);
    if (!streaming) {
      ++preroll_frames;
      streaming = connected && fs->published_epoch.has_value();
      char wait[160];
      std::snprintf(wait, sizeof wait, "gauss-view: waiting for the stream from %s (%s)", src.describe().c_str(),
                    connected ? "connected" : "connecting");
      status.update(wait);
      if (!streaming) std::this_thread::sleep_for(std::chrono::milliseconds(10));  // leave the cores to the host
      continue;
    }
    if (opts.every > 0 && path_frame < path_frames && path_frame % opts.every == 0) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06llu", static_cast<unsigned long long>(path_frame));
      if (auto st = write_views(src, opts.out / "frames" / name, views); !st) {
        std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
        return 1;
      }
    }
    char line[160];
    std::snprintf(line, sizeof line, "gauss-view: frame %llu t %.2f s  resident %u  pending %u  cpu %.1f ms",
                  static_cast<unsigned long long>(frame), t, fs->resident, fs->pending, fs->cpu_ms);
    status.update(line);
    if (++path_frame >= path_frames) {
      if (!settle_start) settle_start = std::chrono::steady_clock::now();
      if (src.settled(opts.quiet_s)) {
        settled = true;
        break;
      }
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - *settle_start).count() > settle_limit) break;
      // Waiting out the quiet time with the camera still and nothing in flight: the next
      // frame would equal this one, so pace it like a display instead of spinning (a
      // 64x48 client redrew one image about 250 times per quiet time, a core's worth
      // per client in the soak). New edits wait at most this long to be published.
      if (fs->pending == 0 && fs->publish.edits() == 0) std::this_thread::sleep_for(kSettleFramePeriod);
    }
  }
  status.done({});
  if (auto st = src.wait_frames(); !st) {
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
    return 1;
  }
  for (const auto& g : src.take_gpu_stats()) log.gpu(g);
  log.flush_all();

  // The final frame: the last camera, after the stream settled.
  if (auto st = write_views(src, opts.out / "final", views); !st) {
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
    return 1;
  }
  if (auto st = write_camera_json(opts.out / "final_camera.json", views == 2 ? render::stereo_eye_camera(camera, opts.stereo_ipd, render::Eye::Left) : camera); !st) {
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
    return 1;
  }

  json summary{{"source", src.describe()},
               {"frames", rendered},
               {"path_frames", path_frames},
               {"preroll_frames", preroll_frames},
               {"settled", settled},
               {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count()},
               {"cpu_ms", {{"p50", percentile(cpu_ms, 0.5)}, {"p95", percentile(cpu_ms, 0.95)}, {"p99", percentile(cpu_ms, 0.99)}}},
               {"gpu_ms",
                {{"p50", percentile(log.gpu_ms_, 0.5)},
                 {"p95", percentile(log.gpu_ms_, 0.95)},
                 {"p99", percentile(log.gpu_ms_, 0.99)}}},
               {"resident", src.renderer().occupied_count()},
               {"rejected_nonfinite", src.renderer().rejected_nonfinite()},
               {"default_camera", std::move(default_camera)}};
  if (rt) {
    const auto per_object = rt->resident_per_object();
    json objects = json::object();
    for (const auto& [id, n] : per_object) objects[std::to_string(id)] = n;
    struct Snap {
      std::size_t desired;
      std::optional<Epoch> published;
      std::uint64_t checksum;
      ClientStatsCounters stats;
    };
    const Snap s = rt->with_state([](const ClientState& st) {
      return Snap{st.desired().desired_count(), st.desired().published_epoch(), st.published_checksum(), st.stats()};
    });
    const auto conn = rt->connection();
    summary["capacity"] = rt->capacity();
    summary["desired"] = s.desired;
    summary["published_epoch"] = epoch_json(s.published);
    summary["published_checksum"] = s.checksum;
    summary["resident_per_object"] = std::move(objects);
    summary["query"] = query_state(*rt, query_rho, per_object);
    summary["queries_at_clear"] = std::move(queries_at_clear);
    summary["stream"] = json{{"batches", s.stats.batches},
                             {"edits_received", s.stats.edits_received},
                             {"rejected_messages", s.stats.rejected_messages},
                             {"resyncs", s.stats.resyncs}};
    summary["connection"] = json{{"server", conn.server},
                                 {"connects", conn.counters.connects},
                                 {"disconnects", conn.counters.disconnects},
                                 {"bytes_received", conn.counters.bytes_received},
                                 {"bytes_sent", conn.counters.bytes_sent},
                                 {"network_thread_cpu_ms", conn.counters.thread_cpu_ms}};
    // The published set in slot order: equal depths blend in slot order, so a render of
    // the same set must load it in this order to be byte-identical (gauss-render --order).
    json slot_ids = json::array();
    for (GaussianId id : rt->with_state([](const ClientState& st) { return st.slots().occupants(); }))
      slot_ids.push_back(to_underlying(id));
    std::ofstream(opts.out / "final_slot_ids.json") << slot_ids.dump() << '\n';
    std::ofstream events(opts.out / "events.jsonl");
    json latency = json::object();
    rt->with_state([&](const ClientState& st) {
      st.events().write_jsonl(events);
      // Seconds from sending each query to its stages on this client.
      for (const auto& [id, sent] : queries_sent) {
        json stages = json::object();
        for (QueryStage stage :
             {QueryStage::Target, QueryStage::Highlight, QueryStage::FirstAdditional, QueryStage::Converged})
          if (const StageEvent* ev = st.events().find_query(0, id, stage)) stages[to_string(stage)] = ev->t - sent;
        latency[std::to_string(id)] = std::move(stages);
      }
      return 0;
    });
    summary["query_latency_s"] = std::move(latency);
  }
  {
    json passes = json::object();
    for (std::size_t i = 0; i < std::size(kGpuPasses); ++i) passes[kGpuPasses[i]] = percentile(log.pass_ms_[i], 0.5);
    summary["gpu_pass_ms_p50"] = std::move(passes);
  }
  std::ofstream(opts.out / "summary.json") << summary.dump(2) << '\n';
  if (opts.every > 0)
    if (auto st = write_contact_sheet(opts.out / "frames", opts.out / "contact_sheet.png"); !st)
      std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
  if (auto st = write_report(opts.out / "report.md", summary); !st)
    std::fprintf(stderr, "gauss-view: %s\n", st.message().c_str());
  std::fprintf(stderr, "gauss-view: %llu frames, %s; wrote %s\n", static_cast<unsigned long long>(rendered),
               settled ? "settled" : "NOT settled within the settle time", opts.out.string().c_str());
  return settled ? 0 : 3;
}

}  // namespace gauss::view
