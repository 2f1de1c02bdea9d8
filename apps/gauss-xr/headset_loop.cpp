#include "headset_loop.h"

#include <algorithm>
#include <atomic>
#include <csignal>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "eye_copy.h"
#include "gauss/client/client_runtime.h"
#include "gauss/client/ray_pick.h"
#include "gauss/engine/scene_up.h"
#include "gauss/engine/scene_view.h"
#include "gauss/engine/camera_io.h"
#include "gauss/xr/xr_controls.h"
#include "gauss/xr/xr_session.h"

namespace gauss::xr_app {

namespace {

using Json = nlohmann::json;

// SIGINT / SIGTERM: leave as the runtime would end the session (outputs written).
std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop.store(true); }

// The queries the controller makes, and what it has sent.
class QueryControl {
 public:
  QueryControl(client::ClientRuntime& runtime, double rho) : runtime_(runtime), rho_(rho) {}

  // Acts on one frame's input. A thumbstick push steps rho by 0.05 (kept on the 0.05 grid, so
  // a share is exactly what the user saw) and re-sends the active query with it.
  void apply(const xr::ControllerInput& in, const glm::dmat4& scene_from_space) {
    if (in.stick_steps != 0) {
      rho_ = std::clamp(std::round(rho_ * 20.0 + in.stick_steps) / 20.0, 0.0, 1.0);
      if (active_) send(*active_, Json{{"kind", "rho"}});
    }
    if (in.clear) {
      runtime_.clear_query();
      active_.reset();
      sent_.push_back(Json{{"kind", "clear"}});
    }
    // The class list and the pick read ClientState, whose lock a publication step holds for
    // its length: they wait for a frame where it is free instead of stalling this one.
    if (in.next_class) class_pending_ = true;
    if (in.trigger_pulled && in.aim_valid) {
      pick_pending_ = in.aim;
      pick_transform_ = scene_from_space;
    }
    if (class_pending_ && next_class()) class_pending_ = false;
    if (pick_pending_ && pick(*pick_pending_)) pick_pending_.reset();
  }
  double rho() const noexcept { return rho_; }
  const Json& sent() const noexcept { return sent_; }

 private:
  void send(msg::Query q, Json what) {
    q.rho = static_cast<float>(rho_);
    active_ = q;
    what["query_id"] = runtime_.send_query(q);
    what["rho"] = rho_;
    sent_.push_back(std::move(what));
  }
  // The next class label (sorted) of the objects the host has described. False: the state
  // was busy, try again next frame.
  bool next_class() {
    const auto taken = runtime_.try_with_state([](const ClientState& s) {
      std::set<std::string> out;
      for (const auto& [id, o] : s.objects())
        if (!o.label.empty()) out.insert(o.label);
      return out;
    });
    if (!taken) return false;
    const std::set<std::string>& labels = *taken;
    if (labels.empty()) return true;
    auto it = labels.upper_bound(last_class_);
    if (it == labels.end()) it = labels.begin();
    last_class_ = *it;
    msg::Query q;
    q.kind = msg::QueryKind::ClassText;
    q.text = last_class_;
    send(q, Json{{"kind", "class"}, {"text", last_class_}});
    return true;
  }
  // An instance query on the object under the aim ray (nothing when it points at none).
  // False: the state was busy, try again next frame.
  bool pick(const xr::XrPose& aim) {
    glm::dvec3 origin, direction;
    xr::aim_ray(aim, pick_transform_, origin, direction);
    const auto taken =
        runtime_.try_with_state([&](const ClientState& s) { return client::pick(s.slots(), origin, direction); });
    if (!taken) return false;
    const auto& hit = *taken;
    if (!hit || hit->object == kNoObject) {
      sent_.push_back(Json{{"kind", "miss"}, {"distance", hit ? Json(hit->distance) : Json(nullptr)}});
      return true;
    }
    msg::Query q;
    q.kind = msg::QueryKind::Instance;
    q.instance = hit->object;
    send(q, Json{{"kind", "instance"}, {"object", to_underlying(hit->object)}, {"distance", hit->distance}});
    return true;
  }

  client::ClientRuntime& runtime_;
  double rho_;
  std::optional<msg::Query> active_;  // the last query sent, until cleared
  bool class_pending_{false};          // asked for, the state busy so far
  std::optional<xr::XrPose> pick_pending_;
  glm::dmat4 pick_transform_{1.0};  // the scene's placement when the trigger was pulled
  std::string last_class_;
  Json sent_ = Json::array();
};

// --out: what a test or a user checks afterwards.
Status write_outputs(const XrOptions& o, client::ClientRuntime& rt, const xr::HeadsetSession& session,
                     const std::vector<std::string>& phases, const xr::FrameTarget* last, const QueryControl& queries,
                     std::uint64_t banner_frames, const Json& scene_up) {
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) return Error{"gauss-xr: --out " + o.out.string() + ": " + ec.message()};
  // The published set in slot order (as gauss-view writes it): a render of the same set in
  // this order is byte-identical (gauss-render --order).
  Json slot_ids = Json::array();
  for (GaussianId id : rt.with_state([](const ClientState& st) { return st.slots().occupants(); }))
    slot_ids.push_back(to_underlying(id));
  std::ofstream(o.out / "final_slot_ids.json") << slot_ids.dump() << '\n';
  // The active query: its targets, |G_obj| as the host reported it, and how many of the
  // client's slots hold them (a test checks min(|G_obj|, floor(rho M))).
  const Json query = rt.with_state([](const ClientState& st) {
    const std::vector<ObjectId> targets = st.query_targets();
    if (targets.empty()) return Json{{"active", false}};
    const std::uint64_t resident = st.count_resident(targets);
    Json ids = Json::array();
    for (ObjectId t : targets) ids.push_back(to_underlying(t));
    return Json{{"active", true},
                {"targets", ids},
                {"target_members", st.query_target_gaussians()},
                {"target_resident", resident}};
  });
  Json summary{{"runtime", session.runtime_name()},
               {"depth_layer", session.depth_layer()},
               {"query", query},
               {"eye_width", session.eye_width()},
               {"eye_height", session.eye_height()},
               {"frames_ended", session.frames_ended()},
               {"frames_rendered", rt.frames_rendered()},
               {"phases", phases},
               {"session_states", session.states_seen()},
               {"banner_frames", banner_frames},
               {"scene_up", scene_up},
               {"connection",
                Json{{"connects", rt.connection().counters.connects},
                     {"disconnects", rt.connection().counters.disconnects},
                     {"welcomes", rt.connection().counters.welcomes}}},
               {"queries", queries.sent()},
               {"rho", queries.rho()},
               {"resident", slot_ids.size()},
               {"published_checksum", rt.with_state([](const ClientState& s) { return s.published_checksum(); })}};
  if (last != nullptr) {
    summary["last_display_time"] = last->display_time;
    for (std::uint32_t eye = 0; eye < 2; ++eye)
      if (auto st = write_camera_json(o.out / ("eye" + std::to_string(eye) + ".camera.json"), last->eyes[eye].camera);
          !st)
        return st;
  }
  std::ofstream(o.out / "summary.json") << summary.dump(2) << '\n';
  return Ok{};
}

}  // namespace

int run_headset(const XrOptions& o) {
  auto fail = [](const std::string& why) {
    std::fprintf(stderr, "gauss-xr: %s\n", why.c_str());
    return 1;
  };
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  xr::HeadsetConfig hc;
  hc.stage_space = o.stage;
  auto session = xr::HeadsetSession::create(hc);
  if (!session) return fail(session.message());
  xr::HeadsetSession& s = **session;
  std::fprintf(stderr, "gauss-xr: %s, %ux%u per eye, on %s\n", s.runtime_name().c_str(), s.eye_width(), s.eye_height(),
               s.context().device_name().c_str());

  client::ClientRuntimeConfig rc;
  rc.state.capacity = o.budget;
  rc.state.name = o.name;
  rc.state.access_token = o.token;
  rc.state.publisher.mode = o.mode;
  rc.max_width = s.eye_width();
  rc.max_height = s.eye_height();
  rc.highlight_query = o.highlight;
  rc.publication_thread = o.publication_thread;
  auto runtime = client::ClientRuntime::create(s.context(), rc);
  if (!runtime) return fail(runtime.message());
  client::ClientRuntime& rt = **runtime;
  net::NetClientConfig net;
  net.server = o.host;
  net.log = [](const std::string& line) { std::fprintf(stderr, "gauss-xr: %s\n", line.c_str()); };
  if (auto st = rt.connect(net); !st) return fail(st.message());
  std::optional<render::DepthProjection> depth;
  if (s.depth_layer()) {
    auto d = render::DepthProjection::create(s.context(), s.eye_width(), s.eye_height());
    if (!d) return fail(d.message());
    depth.emplace(std::move(*d));
  }
  auto controls = xr::Controls::create(s.instance(), s.handle(), s.space());
  if (!controls) return fail(controls.message());
  QueryControl queries(rt, o.rho);
  // The scene stands upright in the room: its up (--up, else the host's) turned to the room's
  // +y about the reference space's origin, and a subject seen from outside (a capture, not a
  // room one stands in) turned to lie straight ahead. Once the host's SceneInfo has come.
  Json scene_up = nullptr;
  auto turn_scene = [&] {
    if (!scene_up.is_null()) return;
    const auto view = rt.try_with_state([](const ClientState& st) { return st.view(); });
    if (!view || !*view) return;  // busy, or no SceneInfo yet: next frame
    const msg::SceneView& v = **view;
    const glm::dvec3 up = o.up ? *o.up : view_up(v);
    std::optional<glm::dvec3> face;
    if (!(v.flags & msg::kViewInside)) face = 0.5 * (glm::dvec3(v.subject_min) + glm::dvec3(v.subject_max));
    glm::dmat4 placement = xr::scene_from_space(up, face);
    // STAGE's origin is the floor: a capture's origin (where its first camera was held) goes to
    // the user's eye height above it (--eye-height: standing by default), not under their feet.
    const double lift = o.stage && face ? o.eye_height : 0.0;
    placement = placement * glm::translate(glm::dmat4(1.0), glm::dvec3(0.0, -lift, 0.0));
    s.set_scene_from_space(placement);
    const char* from = o.up ? "--up" : "announced by the host";
    scene_up = Json{{"up", {up.x, up.y, up.z}}, {"from", from}, {"facing_subject", face.has_value()}, {"origin_height", lift}};
    std::fprintf(stderr, "gauss-xr: the scene's up is %s (%s): it stands upright in the room%s\n",
                 up_label(up).c_str(), from, face ? ", its subject ahead" : "");
  };

  std::vector<std::string> phases;
  std::optional<xr::FrameTarget> last;
  XrTime input_time = 0;
  bool exit_requested = false;
  std::uint64_t banner_frames = 0;  // frames shown with the host-unreachable banner
  for (;;) {
    auto phase = s.poll();
    if (!phase) return fail(phase.message());
    if (phases.empty() || phases.back() != xr::to_string(*phase)) phases.push_back(xr::to_string(*phase));
    if (*phase == xr::SessionPhase::Exiting) break;
    if (*phase == xr::SessionPhase::LossPending) {
      // The runtime is taking the session away (the headset was removed from use, the
      // runtime restarts): leave cleanly rather than render into a dead session.
      (void)rt.wait_frames();
      if (!o.out.empty()) (void)write_outputs(o, rt, s, phases, last ? &*last : nullptr, queries, banner_frames, scene_up);
      return fail("the OpenXR session was lost; exiting");
    }
    if (*phase != xr::SessionPhase::Running) {
      if (g_stop.load() && *phase == xr::SessionPhase::Idle) break;  // never began: nothing to end
      std::this_thread::sleep_for(std::chrono::milliseconds(5));  // idle or stopping: no frames
      continue;
    }
    if (input_time != 0) {
      auto in = (*controls)->read(input_time);
      if (!in) return fail(in.message());
      queries.apply(*in, s.scene_from_space());
    }
    // No window to print to in a headset: while the host is unreachable (not yet welcomed,
    // gone, refusing us) the last published scene stays drawn and a banner says so.
    s.show_banner(rt.connection().status != net::ClientStatus::Connected);
    turn_scene();
    std::optional<xr::FrameTarget> shown;
    auto rendered = s.frame([&](const xr::FrameTarget& t) -> Status {
      const Camera cams[2] = {t.eyes[0].camera, t.eyes[1].camera};
      render::FrameHooks hooks;
      hooks.record_after = [&](VkCommandBuffer cmd) {
        return record_eye_copy(cmd, rt.renderer(), t, depth ? &*depth : nullptr);
      };
      auto fs = rt.frame(std::span<const Camera>(cams, 2), hooks);
      if (!fs) return fs.error();
      shown = t;
      return Ok{};
    });
    if (!rendered) return fail(rendered.message());
    if (shown) {
      input_time = shown->display_time;
      last = shown;
      if (s.banner_shown()) ++banner_frames;
    }
    if (((o.max_frames > 0 && s.frames_ended() >= o.max_frames) || g_stop.load()) && !exit_requested) {
      exit_requested = true;
      if (auto st = s.request_exit(); !st) return fail(st.message());
    }
  }
  if (auto st = rt.wait_frames(); !st) return fail(st.message());
  if (!o.out.empty())
    if (auto st = write_outputs(o, rt, s, phases, last ? &*last : nullptr, queries, banner_frames, scene_up); !st)
      return fail(st.message());
  std::fprintf(stderr, "gauss-xr: session ended after %llu frames\n",
               static_cast<unsigned long long>(s.frames_ended()));
  return 0;
}

}  // namespace gauss::xr_app
