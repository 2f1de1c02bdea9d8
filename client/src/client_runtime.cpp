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
  if (rt->config_.publication_thread) {
    ClientRuntime* self = rt.get();
    rt->worker_ = std::make_unique<StepThread<PublicationJob, PreparedStep>>(
        [self](PublicationJob& job) { return self->prepare_step(job); });
  }
  return rt;
}

ClientRuntime::ClientRuntime(vk::Context& context, ClientRuntimeConfig config, std::unique_ptr<ClientState> state)
    : context_(&context), config_(std::move(config)), state_(std::move(state)) {
  sink_ = std::make_unique<net::ClientStateSink>(*state_, config_.clock);
}

ClientRuntime::~ClientRuntime() {
  worker_.reset();  // the publication thread stops before the state and renderer it uses
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
                                                     .frames_in_flight = config_.frames_in_flight,
                                                     .upload_scatter_min_regions = config_.upload_scatter_min_regions});
  if (!r) return Error{"ClientRuntime: " + r.message()};
  renderer_ = std::move(*r);
  gpu_stats_.clear();
  highlighted_.clear();
  if (config_.publication_thread) {
    // Pack buffers in the new renderer's slot layout; its frame serials start afresh.
    pack_pool_.clear();
    unsubmitted_.clear();
    const render::SlotLayout layout = renderer_->slot_layout();
    const std::uint32_t slots = config_.pack_slots_per_step == 0 ? config_.state.capacity
                                                                 : std::min(config_.state.capacity, config_.pack_slots_per_step);
    // frames_in_flight + 2: when a step is asked for (before this frame is submitted) the
    // buffer of the step this frame applies and those of the frames_in_flight frames before
    // it may all be busy; one more is always free. With one fewer, a CPU a whole ring ahead
    // of the GPU (an H100 replaying recorded passes) found none and wrote a step's slots on
    // the display thread (ClientRuntimeInProcess.PublicationThreadShowsTheSameSet: 1700 of
    // 2100 slots packed).
    for (std::uint32_t i = 0; i < config_.frames_in_flight + 2; ++i) {
      // Storage usage: a step's many runs reach the slots through StagedUploads' compute
      // scatter, which binds a window of the pack buffer (so it may exceed one binding).
      auto b = vk::Buffer::create(*context_, {.size = VkDeviceSize{slots} * layout.bytes_per_slot(),
                                              .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                              .memory = vk::MemoryUsage::HostVisible,
                                              .name = "publication pack buffer " + std::to_string(i),
                                              .allow_larger_than_binding_range = true});
      if (!b) return Error{"ClientRuntime: " + b.message()};
      pack_pool_.push_back(PackBuffer{std::move(*b)});
    }
  }
  // Under the state lock (the network thread changes the surface stage); called while no
  // publication step runs, so the wait is for a message at most. A new SH degree is rare.
  return sink_->with_state(
      [&](ClientState& s) { return publication_.republish_all(s.slots(), s.surface(), *renderer_); });
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

void ClientRuntime::join_lockstep_step() {
  if (worker_ && config_.publication_lockstep) worker_->wait_idle();
}

void ClientRuntime::deliver(const wire::Message& message) {
  join_lockstep_step();
  if (const auto* w = std::get_if<msg::Welcome>(&message)) {
    sink_->on_welcome(*w);
  } else if (const auto* r = std::get_if<msg::Refuse>(&message)) {
    sink_->on_refused(*r);
  } else {
    wire::Message copy = message;
    sink_->on_message(std::move(copy));
  }
}

std::vector<wire::Message> ClientRuntime::take_outgoing() {
  join_lockstep_step();
  return sink_->take_outgoing();
}

ClientRuntime::PreparedStep ClientRuntime::prepare_step(PublicationJob& job) {
  PreparedStep st;
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = thread_cpu_ms();
  auto fr = sink_->with_state([&](ClientState& s) -> Expected<FrameResult> {
    st.lock_wait_ms = ms_since(t0);
    for (msg::Query& q : job.queries) s.send_reserved_query(std::move(q));
    if (job.mode) s.set_publish_mode(*job.mode);
    if (job.display_period) s.set_display_period(*job.display_period);
    if (job.pose) s.send_pose(*job.pose);
    for (const RenderedNote& n : job.rendered) s.frame_rendered(n.now, n.frame_index, n.shown_step);
    for (double cost : job.frame_costs) s.report_frame_cost(cost);
    auto r = s.frame(job.view, job.now, job.frame_index);
    // Under the lock: the network thread changes the stage (a restarted host's epochs).
    if (r) st.surface = publication_.prepare_surface(s.surface());
    if (s.codec()) st.sh_degree = s.codec()->sh_degree;
    if (job.highlight_query) st.targets = s.query_targets();
    st.desired = s.desired().desired_count();
    st.pending = static_cast<std::uint32_t>(s.desired().pending().size());
    st.resident = s.slots().size();
    st.welcomed = s.welcomed();
    st.counters = s.stats();
    return r;
  });
  st.publish_ms = ms_since(t0);
  const double c1 = thread_cpu_ms();
  st.publish_cpu_ms = c1 - c0;
  st.pack_buffer = job.pack_buffer;
  if (!fr) {
    st.error = fr.message();
    return st;
  }
  st.result = std::move(*fr);
  // Outside the lock: only this step writes the slot table. A step that changes the SH
  // degree packs nothing (the renderer is made again and takes every slot anew).
  const auto t1 = std::chrono::steady_clock::now();
  const bool same_layout = !st.sh_degree || *st.sh_degree == job.layout.sh_degree;
  st.slots = GpuPublication::prepare_slots(state_->slots(), st.result.ranges, job.layout,
                                           same_layout ? job.pack : std::span<std::byte>{});
  st.pack_ms = ms_since(t1);
  st.pack_cpu_ms = thread_cpu_ms() - c1;
  return st;
}

Status ClientRuntime::apply_step(PreparedStep& st, DisplayFrameStats& out) {
  // The pack buffer goes back unless copies from it were queued (then after their frame).
  auto release = [&] {
    if (st.pack_buffer >= 0) pack_buffer(st.pack_buffer).taken = false;
    st.pack_buffer = -1;
  };
  if (!st.error.empty()) {
    release();
    return Error{st.error};
  }
  out.step_taken = true;
  out.step_publish_cpu_ms = st.publish_cpu_ms;
  out.step_pack_cpu_ms = st.pack_cpu_ms;
  out.step_publish_ms = st.publish_ms;
  out.step_pack_ms = st.pack_ms;
  out.publish = st.result.publish;
  out.ranges = static_cast<std::uint32_t>(st.result.ranges.size());
  out.published_epoch = st.result.published_epoch;
  out.surface_epoch = st.result.surface_epoch;
  last_desired_ = st.desired;
  last_pending_ = st.pending;
  last_resident_ = st.resident;
  last_welcomed_ = st.welcomed;
  last_counters_ = st.counters;
  shown_step_ = st.result.step;
  if (st.sh_degree && *st.sh_degree != renderer_->sh_degree()) {
    release();
    if (auto s = make_renderer(*st.sh_degree); !s) return s;
  } else {
    const vk::Buffer* source = st.pack_buffer >= 0 ? &pack_buffer(st.pack_buffer).buffer : nullptr;
    auto up = publication_.publish_prepared(st.slots, source, state_->slots(), *renderer_, config_.tint_edits);
    if (!up) {
      // Copies queued before the failure may still read the buffer: keep it to the next frame.
      if (st.pack_buffer >= 0) unsubmitted_.push_back(st.pack_buffer);
      return up.error();
    }
    out.uploaded = *up;
    if (st.pack_buffer >= 0) {
      if (up->slots_packed > 0) {
        unsubmitted_.push_back(st.pack_buffer);
      } else {
        release();
      }
    }
    out.uploaded.chunks_changed = publication_.publish_prepared_surface(st.surface, *renderer_);
  }
  if (st.targets != highlighted_) {
    if (st.targets.empty()) {
      renderer_->clear_highlight();
    } else if (auto s = renderer_->set_highlight(st.targets); !s) {
      return s.error();
    }
    highlighted_ = st.targets;
  }
  return Ok{};
}

int ClientRuntime::free_pack_buffer() {
  const std::uint64_t done = renderer_->frames().poll();
  for (std::size_t i = 0; i < pack_pool_.size(); ++i) {
    PackBuffer& b = pack_pool_[i];
    if (!b.taken && b.serial <= done) {
      b.taken = true;
      return static_cast<int>(i);
    }
  }
  return -1;
}

Expected<DisplayFrameStats> ClientRuntime::frame(std::span<const Camera> views, const render::FrameHooks& hooks) {
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = thread_cpu_ms();
  if (views.empty() || views.size() > 2)
    return Error{"ClientRuntime::frame: 1 or 2 views, not " + std::to_string(views.size())};
  DisplayFrameStats out;
  out.frame_index = frame_index_;
  out.now = now();
  out.publication_threaded = worker_ != nullptr;
  PublicationJob& job = next_job_;
  job.view = view_state_of(views[0]);
  job.now = out.now;
  job.frame_index = frame_index_;
  job.highlight_query = config_.highlight_query;
  if (config_.pose_period_s == 0.0 || out.now - last_pose_time_ >= config_.pose_period_s) {
    job.pose = head_pose_from_camera(views[0]);
    job.pose->client_time_us = static_cast<std::uint64_t>(std::max(0.0, out.now) * 1e6);
    last_pose_time_ = out.now;
  }

  // --- publication: this frame's step (no thread), or the one the thread finished ---
  std::optional<PreparedStep> step;
  if (worker_) {
    join_lockstep_step();  // lock step: the step asked for last frame is always this frame's
    step = worker_->take();
  } else {
    job.layout = renderer_->slot_layout();
    step = prepare_step(job);
    job = PublicationJob{};
    out.lock_wait_ms = step->lock_wait_ms;
  }
  out.publish_ms = ms_since(t0);
  const double c1 = thread_cpu_ms();
  out.publish_cpu_ms = c1 - c0;

  // --- GPU publication (display thread; the publication thread is idle until asked again) ---
  const auto t1 = std::chrono::steady_clock::now();
  if (step)
    if (auto st = apply_step(*step, out); !st) return st.error();
  out.desired = last_desired_;
  out.pending = last_pending_;
  out.resident = last_resident_;
  out.welcomed = last_welcomed_;
  out.counters = last_counters_;
  if (worker_) {
    job.layout = renderer_->slot_layout();
    job.pack_buffer = free_pack_buffer();
    job.pack = job.pack_buffer >= 0 ? pack_buffer(job.pack_buffer).bytes() : std::span<std::byte>{};
    if (worker_->request(job)) {
      requested_at_ = std::chrono::steady_clock::now();
      job = PublicationJob{};
    } else if (job.pack_buffer >= 0) {
      pack_buffer(job.pack_buffer).taken = false;  // the notes wait for the next request
      job.pack_buffer = -1;
    }
  }
  out.upload_ms = ms_since(t1);
  out.upload_cpu_ms = thread_cpu_ms() - c1;

  // --- render ---
  const auto t2 = std::chrono::steady_clock::now();
  const vk::StagedUploadStats uploads_before = renderer_->uploads().stats();
  auto serial = renderer_->render_frame(views, config_.render, hooks);
  if (!serial) return serial.error();
  for (int b : unsubmitted_) {
    pack_buffer(b).serial = *serial;
    pack_buffer(b).taken = false;
  }
  unsubmitted_.clear();
  const vk::StagedUploadStats& uploads_after = renderer_->uploads().stats();
  out.copy_regions = static_cast<std::uint32_t>(uploads_after.copy_regions - uploads_before.copy_regions);
  out.scatter_regions = static_cast<std::uint32_t>(uploads_after.scatter_regions - uploads_before.scatter_regions);
  out.scatter_pieces = static_cast<std::uint32_t>(uploads_after.scatter_pieces - uploads_before.scatter_pieces);
  out.serial = *serial;
  out.render_ms = ms_since(t2);
  gpu_stats_.submitted(*serial, frame_index_, static_cast<std::uint32_t>(views.size()));
  // Stamped when the frame was submitted, not when it began: a query's resolution or a batch
  // that arrived while this frame was being prepared is in it, and its "shown" stage must not
  // come out earlier than its arrival. (A simulation's clock stands still within a frame.)
  const RenderedNote shown{now(), frame_index_, shown_step_};
  gpu_stats_.collect(*renderer_);
  out.cpu_ms = ms_since(t0);
  // The display slack the allowance follows: the frame costs whichever of the CPU work
  // and the GPU work of a frame is longer (they overlap with frames in flight), and with
  // the publication thread whichever is longer still, the step this frame took or the one
  // still running: publication keeps the display's pace, one step a frame, instead of
  // growing into steps that span frames and land in bursts.
  double cost_ms = std::max(out.cpu_ms, gpu_stats_.last_total_ms());
  if (worker_) {
    if (step) cost_ms = std::max(cost_ms, step->publish_ms + step->pack_ms);
    else if (worker_->outstanding()) cost_ms = std::max(cost_ms, ms_since(requested_at_));
  }
  const double cost = cost_ms * 1e-3;
  if (worker_) {
    next_job_.rendered.push_back(shown);
    next_job_.frame_costs.push_back(cost);
  } else {
    sink_->with_state([&](ClientState& s) {
      s.frame_rendered(shown.now, shown.frame_index, shown.shown_step);
      s.report_frame_cost(cost);
    });
  }
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
  if (!worker_) return sink_->with_state([&](ClientState& s) { return s.send_query(std::move(query)); });
  query.query_id = state_->reserve_query_id();  // atomic: no wait for a running step
  next_job_.queries.push_back(std::move(query));
  return next_job_.queries.back().query_id;
}

void ClientRuntime::clear_query() {
  msg::Query q;
  q.kind = msg::QueryKind::Clear;
  send_query(q);
}

void ClientRuntime::set_publish_mode(PublishMode mode) {
  mode_ = mode;
  if (worker_) {
    next_job_.mode = mode;
    return;
  }
  sink_->with_state([&](ClientState& s) { s.set_publish_mode(mode); });
}

void ClientRuntime::set_display_period(double seconds) {
  if (worker_) {
    next_job_.display_period = seconds;
    return;
  }
  sink_->with_state([&](ClientState& s) { s.set_display_period(seconds); });
}

std::map<std::int32_t, std::uint32_t> ClientRuntime::resident_per_object(const ClientState& state) {
  std::map<std::int32_t, std::uint32_t> out;
  const SlotTable& slots = state.slots();
  for (std::uint32_t s = 0; s < slots.capacity(); ++s) {
    GaussianId id{0};
    if (slots.occupant(SlotIndex{s}, id)) ++out[to_underlying(slots.records()[s].object)];
  }
  return out;
}

std::map<std::int32_t, std::uint32_t> ClientRuntime::resident_per_object() {
  // Under the lock: a publication thread writes the slot table under it.
  return with_state([](const ClientState& st) { return resident_per_object(st); });
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
