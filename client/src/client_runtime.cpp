// ClientRuntime: transport -> ClientState -> GPU publication -> renderer, per display frame.
#include "gauss/client/client_runtime.h"

#include <time.h>

#include <algorithm>
#include <chrono>

#include "gauss/engine/host_session.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"

namespace gauss::client {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// CPU time of the calling thread, ms.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

ViewState view_state_of(const Camera& camera) {
  const ClientPose p = ClientPose::from_camera(camera);
  ViewState v;
  v.eye = glm::vec3(p.position);
  // OpenCV camera: +z looks forward.
  const glm::dmat3 r_cw(camera.world_to_camera);
  v.forward = glm::vec3(glm::normalize(glm::transpose(r_cw) * glm::dvec3(0.0, 0.0, 1.0)));
  return v;
}

}  // namespace

Expected<std::unique_ptr<ClientRuntime>> ClientRuntime::create(vk::Context& context, ClientRuntimeConfig config) {
  if (!config.clock) {
    const auto origin = std::chrono::steady_clock::now();
    config.clock = [origin] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - origin).count(); };
  }
  if (!(config.pose_period_s >= 0.0)) return Error{"ClientRuntime: pose_period_s must be >= 0"};
  auto state = ClientState::create(0, config.state);
  if (!state) return Error{"ClientRuntime: " + state.message()};
  std::unique_ptr<ClientRuntime> rt(
      new ClientRuntime(context, std::move(config), std::make_unique<ClientState>(std::move(*state))));
  rt->mode_ = rt->config_.state.publisher.mode;
  if (auto st = rt->make_renderer(0); !st) return st.error();
  return rt;
}

ClientRuntime::ClientRuntime(vk::Context& context, ClientRuntimeConfig config, std::unique_ptr<ClientState> state)
    : context_(&context), config_(std::move(config)), state_(std::move(state)) {
  sink_ = std::make_unique<net::ClientStateSink>(*state_, config_.clock);
}

ClientRuntime::~ClientRuntime() {
  net_.reset();  // the network thread stops before the state it feeds goes
  if (renderer_) (void)renderer_->frames().wait_all();
}

Status ClientRuntime::make_renderer(int sh_degree) {
  if (renderer_) {
    if (auto st = renderer_->frames().wait_all(); !st) return st;
  }
  renderer_.reset();
  auto r = render::SplatRenderer::create(*context_, {.capacity = config_.state.capacity,
                                                     .sh_degree = sh_degree,
                                                     .max_width = config_.max_width,
                                                     .max_height = config_.max_height,
                                                     .frames_in_flight = config_.frames_in_flight});
  if (!r) return Error{"ClientRuntime: " + r.message()};
  renderer_ = std::move(*r);
  gpu_stats_.clear();
  highlighted_.clear();
  return publication_.republish_all(state_->slots(), state_->surface(), *renderer_);
}

Status ClientRuntime::connect(net::NetClientConfig net) {
  if (net_) return Error{"ClientRuntime::connect: already connected to " + server_};
  net.slot_capacity = config_.state.capacity;
  net.access_token = config_.state.access_token;
  net.name = config_.state.name;
  server_ = net::to_string(net.server);
  auto c = net::NetClient::start(std::move(net), *sink_);
  if (!c) return Error{"ClientRuntime::connect: " + c.message()};
  net_ = std::move(*c);
  return Ok{};
}

void ClientRuntime::deliver(const wire::Message& message) {
  if (const auto* w = std::get_if<msg::Welcome>(&message)) {
    sink_->on_welcome(*w);
  } else if (const auto* r = std::get_if<msg::Refuse>(&message)) {
    sink_->on_refused(*r);
  } else {
    wire::Message copy = message;
    sink_->on_message(std::move(copy));
  }
}

std::vector<wire::Message> ClientRuntime::take_outgoing() { return sink_->take_outgoing(); }

Expected<DisplayFrameStats> ClientRuntime::frame(std::span<const Camera> views, const render::FrameHooks& hooks) {
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = thread_cpu_ms();
  if (views.empty() || views.size() > 2)
    return Error{"ClientRuntime::frame: 1 or 2 views, not " + std::to_string(views.size())};
  DisplayFrameStats out;
  out.frame_index = frame_index_;
  out.now = now();
  const ViewState view = view_state_of(views[0]);

  // --- publication (ClientState's lock, briefly) ---
  std::optional<int> sh_degree;
  std::vector<ObjectId> targets;
  auto fr = sink_->with_state([&](ClientState& s) -> Expected<FrameResult> {
    out.lock_wait_ms = ms_since(t0);
    if (config_.pose_period_s == 0.0 || out.now - last_pose_time_ >= config_.pose_period_s) {
      msg::HeadPose pose = head_pose_from_camera(views[0]);
      pose.client_time_us = static_cast<std::uint64_t>(std::max(0.0, out.now) * 1e6);
      s.send_pose(pose);
      last_pose_time_ = out.now;
    }
    auto r = s.frame(view, out.now, frame_index_);
    if (s.codec()) sh_degree = s.codec()->sh_degree;
    if (config_.highlight_query) targets = s.query_targets();
    out.desired = s.desired().desired_count();
    out.pending = static_cast<std::uint32_t>(s.desired().pending().size());
    return r;
  });
  if (!fr) return fr.error();
  out.publish_ms = ms_since(t0);
  const double c1 = thread_cpu_ms();
  out.publish_cpu_ms = c1 - c0;
  out.publish = fr->publish;
  out.ranges = static_cast<std::uint32_t>(fr->ranges.size());
  out.published_epoch = fr->published_epoch;
  out.surface_epoch = fr->surface_epoch;

  // --- GPU publication (display thread only: it alone writes slots and the surface) ---
  const auto t1 = std::chrono::steady_clock::now();
  if (sh_degree && *sh_degree != renderer_->sh_degree()) {
    if (auto st = make_renderer(*sh_degree); !st) return st.error();
  } else {
    auto up = publication_.publish_slots(state_->slots(), fr->ranges, *renderer_, config_.tint_edits);
    if (!up) return up.error();
    out.uploaded = *up;
    out.uploaded.chunks_changed = publication_.publish_surface(state_->surface(), *renderer_);
  }
  if (targets != highlighted_) {
    if (targets.empty()) {
      renderer_->clear_highlight();
    } else if (auto st = renderer_->set_highlight(targets); !st) {
      return st.error();
    }
    highlighted_ = targets;
  }
  out.resident = state_->slots().size();
  out.upload_ms = ms_since(t1);
  out.upload_cpu_ms = thread_cpu_ms() - c1;

  // --- render ---
  const auto t2 = std::chrono::steady_clock::now();
  const std::uint64_t regions_before = renderer_->uploads().stats().copy_regions;
  auto serial = renderer_->render_frame(views, config_.render, hooks);
  if (!serial) return serial.error();
  out.copy_regions = static_cast<std::uint32_t>(renderer_->uploads().stats().copy_regions - regions_before);
  out.serial = *serial;
  out.render_ms = ms_since(t2);
  gpu_stats_.submitted(*serial, frame_index_, static_cast<std::uint32_t>(views.size()));
  // Stamped when the frame was submitted, not when it began: a query's resolution or a batch
  // that arrived while this frame was being prepared is in it, and its "shown" stage must not
  // come out earlier than its arrival. (A simulation's clock stands still within a frame.)
  sink_->with_state([&](ClientState& s) { s.frame_rendered(now(), frame_index_); });
  gpu_stats_.collect(*renderer_);
  out.cpu_ms = ms_since(t0);
  // The display slack the allowance follows: the frame costs whichever of the CPU work
  // and the GPU work of a frame is longer (they overlap with frames in flight).
  sink_->with_state([&](ClientState& s) { s.report_frame_cost(std::max(out.cpu_ms, gpu_stats_.last_total_ms()) * 1e-3); });
  ++frame_index_;
  return out;
}

std::vector<GpuFrameStats> ClientRuntime::take_gpu_stats() { return gpu_stats_.take(*renderer_); }

Status ClientRuntime::wait_frames() {
  if (auto st = renderer_->frames().wait_all(); !st) return st;
  gpu_stats_.collect(*renderer_);
  return Ok{};
}

std::uint32_t ClientRuntime::send_query(msg::Query query) {
  return sink_->with_state([&](ClientState& s) { return s.send_query(std::move(query)); });
}

void ClientRuntime::clear_query() {
  msg::Query q;
  q.kind = msg::QueryKind::Clear;
  send_query(q);
}

void ClientRuntime::set_publish_mode(PublishMode mode) {
  mode_ = mode;
  sink_->with_state([&](ClientState& s) { s.set_publish_mode(mode); });
}

void ClientRuntime::set_display_period(double seconds) {
  sink_->with_state([&](ClientState& s) { s.set_display_period(seconds); });
}

std::map<std::int32_t, std::uint32_t> ClientRuntime::resident_per_object() {
  std::map<std::int32_t, std::uint32_t> out;
  const SlotTable& slots = state_->slots();
  for (std::uint32_t s = 0; s < slots.capacity(); ++s) {
    GaussianId id{0};
    if (slots.occupant(SlotIndex{s}, id)) ++out[to_underlying(slots.records()[s].object)];
  }
  return out;
}

ConnectionInfo ClientRuntime::connection() const {
  ConnectionInfo c;
  c.networked = net_ != nullptr;
  c.server = server_;
  if (net_) {
    c.status = net_->status();
    c.counters = net_->counters();
  }
  return c;
}

}  // namespace gauss::client
