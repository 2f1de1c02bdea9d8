// Temporal behaviour per publication mode: teleport far away, return, convergence and
// post-convergence flicker, on the real client path.
//
// Per mode, on a fresh connection at M = --budget: settle at A (fidelity camera 0);
// teleport to B (A's eye mirrored through the room centre, looking the other way) and
// settle; return to A and keep every frame until the client has converged. Then:
//   - published == desired: virtual seconds from the return to the first frame of the
//     final in-sync run (EvalSession::settle), and to the first in-sync frame;
//   - SSIM convergence: the first frame from which every later frame has SSIM >= 0.99
//     against the settled frame (the last one), in virtual seconds from the return;
//   - flicker: a window of --flicker-window seconds after convergence while the head
//     sways (5 cm at 0.3 Hz sideways, 3 cm at 0.45 Hz forward, 3 degrees of yaw at
//     0.2 Hz, as gauss-bench stream): the client renders two views, the swaying head (its
//     pose goes to the host) and A held still; flicker = the mean absolute change per
//     pixel and channel (8-bit levels) between consecutive frames of A; churn = slot
//     writes and published-set membership changes in the window.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <glm/mat4x4.hpp>

#include "measurements.h"

namespace gauss::eval_app {

namespace {

constexpr double kSsimConverged = 0.99;

std::vector<std::uint64_t> published_ids(EvalSession& session) {
  std::vector<std::uint64_t> ids;
  for (const auto& [slot, id] : session.slot_ids()) ids.push_back(to_underlying(id));
  std::sort(ids.begin(), ids.end());
  return ids;
}

Expected<Json> measure_mode(Room& room, PublishMode mode, Json& timing) {
  const Options& o = room.options;
  const EvalScene& scene = room.scene;
  const char* name = mode == PublishMode::Progressive ? "progressive" : "immediate";
  auto stream = open_stream(room, o.budget, mode);
  if (!stream) return stream.error();
  EvalSession& session = *stream->session;
  const Camera a = scene.cameras.front();
  const Camera b = teleport_target(a, scene);
  room.progress(std::string("temporal ") + name + ": settling at A");
  auto first = session.settle(a, o.settle_timeout_s, o.quiet_s);
  if (!first) return first.error();
  room.progress(std::string("temporal ") + name + ": teleport to B");
  auto away = session.settle(b, o.settle_timeout_s, o.quiet_s);
  if (!away) return away.error();

  // Return to A: every frame kept until converged.
  room.progress(std::string("temporal ") + name + ": return to A");
  std::vector<ImageRGBA8> frames;
  std::vector<double> frame_t;
  Status read_error = Ok{};
  const auto back = session.settle(a, o.settle_timeout_s, o.quiet_s, [&](const client::DisplayFrameStats& f) {
    if (!read_error) return;
    auto img = session.client().renderer().read_image();
    if (!img) {
      read_error = img.error();
      return;
    }
    frames.push_back(std::move(*img));
    frame_t.push_back(f.now);
  });
  if (!back) return back.error();
  if (!read_error) return read_error.error();
  std::vector<double> ssim_to_settled;
  double ssim_conv = -1.0;
  if (!frames.empty()) {
    const ImageRGBA8& settled = frames.back();
    for (const ImageRGBA8& f : frames) {
      auto s = eval::ssim(view_of(settled), view_of(f));
      if (!s) return Error{"SSIM to the settled frame: " + s.message()};
      ssim_to_settled.push_back(*s);
    }
    std::size_t k = frames.size();
    while (k > 0 && ssim_to_settled[k - 1] >= kSsimConverged) --k;
    ssim_conv = frame_t[k] - back->start_s;
  }
  double min_ssim = 1.0;
  for (double s : ssim_to_settled) min_ssim = std::min(min_ssim, s);

  // Flicker window: the head sways, A is rendered as a second view and compared frame to frame.
  room.progress(std::string("temporal ") + name + ": flicker window");
  const std::vector<std::uint64_t> ids_before = published_ids(session);
  const std::uint64_t messages_before = session.messages_down();
  std::uint64_t writes = 0, membership = 0;
  eval::FrameChange change;
  std::uint64_t window_frames = 0;
  std::vector<double> window_cpu_ms;
  const double w0 = session.now();
  while (session.now() - w0 < o.flicker_window_s) {
    const Camera views[2] = {swayed(a, session.now() - w0), a};
    auto f = session.step_views(views);
    if (!f) return f.error();
    ++window_frames;
    writes += f->publish.slot_writes();
    membership += f->publish.inserted + f->publish.removed + 2ull * f->publish.replaced;
    window_cpu_ms.push_back(f->cpu_ms);
    auto img = session.client().renderer().read_image(1);
    if (!img) return img.error();
    if (auto st = change.add(view_of(*img)); !st) return st.error();
  }
  const std::vector<std::uint64_t> ids_after = published_ids(session);
  std::vector<std::uint64_t> net;
  std::set_symmetric_difference(ids_before.begin(), ids_before.end(), ids_after.begin(), ids_after.end(),
                                std::back_inserter(net));
  room.timing.add_gpu(session.client().take_gpu_stats());
  timing[name] = Json{{"return_frame_cpu_ms", percentiles(back->frame_cpu_ms)},
                      {"window_frame_cpu_ms", percentiles(window_cpu_ms)}};
  room.timing.frame_cpu_ms.insert(room.timing.frame_cpu_ms.end(), back->frame_cpu_ms.begin(), back->frame_cpu_ms.end());

  Json ssim_list = Json::array();
  for (double s : ssim_to_settled) ssim_list.push_back(number(s));
  return Json{{"mode", name},
              {"a", camera_json(a)},
              {"b", camera_json(b)},
              {"first", settle_json(*first)},
              {"teleport", settle_json(*away)},
              {"return", settle_json(*back)},
              {"published_equals_desired_s", number(back->converged_s)},
              {"ssim_convergence_s", number(ssim_conv)},
              {"ssim_threshold", kSsimConverged},
              {"min_ssim_to_settled", number(min_ssim)},
              {"ssim_to_settled", std::move(ssim_list)},
              {"flicker", Json{{"window_s", session.now() - w0},
                               {"frames", window_frames},
                               {"mean_abs_change", change.mean()},
                               {"max_abs_change", change.max()},
                               {"slot_writes", writes},
                               {"membership_changes", membership},
                               {"net_set_changes", net.size()},
                               {"host_messages", session.messages_down() - messages_before}}},
              {"stream", stream_json(session)}};
}

}  // namespace

Camera teleport_target(const Camera& a, const EvalScene& scene) {
  const glm::dvec3 e = eye_of(a), f = forward_of(a);
  if (!scene.synthetic) {
    // Around a scene file: the eye mirrored across the vertical axis through the centre
    // and brought in to 0.4 of its distance, looking at the centre: a close-up of the far
    // side. (At the orbit distance a small scene fits the budget's selection alike from
    // both sides, and the teleport would change nothing.)
    const glm::dvec3 c = 0.5 * (scene.region_min + scene.region_max);
    const glm::dvec3 d = e - c;
    const glm::dvec3 vertical = glm::dot(d, scene.up) * scene.up;
    Camera b = look_camera(c + 0.4 * (vertical - (d - vertical)), c, a.width, a.height, scene.up);
    b.fx = a.fx;
    b.fy = a.fy;
    b.cx = a.cx;
    b.cy = a.cy;
    return b;
  }
  const glm::dvec3 lo(scene.region_min), hi(scene.region_max);
  glm::dvec3 eye(lo.x + hi.x - e.x, e.y, lo.z + hi.z - e.z);
  eye = glm::clamp(eye, lo + 0.25, hi - 0.25);
  glm::dvec3 dir(-f.x, f.y, -f.z);
  if (glm::length(glm::dvec3(dir.x, 0.0, dir.z)) < 1e-3) dir = glm::dvec3(1.0, 0.0, 0.0);
  Camera b = look_camera(eye, eye + dir, a.width, a.height);
  b.fx = a.fx;
  b.fy = a.fy;
  b.cx = a.cx;
  b.cy = a.cy;
  return b;
}

Expected<Json> measure_temporal(Room& room) {
  const auto t0 = std::chrono::steady_clock::now();
  Json out = Json::array();
  Json timing = Json::object();
  for (PublishMode mode : {PublishMode::Progressive, PublishMode::Immediate}) {
    auto m = measure_mode(room, mode, timing);
    if (!m) return Error{room.scene.name + " temporal (" + (mode == PublishMode::Progressive ? "progressive" : "immediate") +
                         "): " + m.message()};
    out.push_back(std::move(*m));
  }
  room.timing.phases["temporal_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  room.timing.phases["temporal_frames"] = std::move(timing);
  return out;
}

}  // namespace gauss::eval_app
