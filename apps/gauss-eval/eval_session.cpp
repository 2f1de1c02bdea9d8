#include "eval_session.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "gauss/engine/wire.h"
#include "gauss/render/splat_renderer.h"
#include "measure.h"

namespace gauss::eval_app {

namespace {

HostSessionConfig host_config(const EvalSessionConfig& c) {
  HostSessionConfig h;
  h.default_rho = c.default_rho;
  if (c.lod) h.lod = LodConfig{};
  return h;
}

}  // namespace

EvalSession::EvalSession(const SceneStore& scene, const CodecParams& params, const EvalSessionConfig& config)
    : scene_(&scene),
      params_(params),
      config_(config),
      host_(1, config.seed, params, host_config(config)),
      down_(config.seed * 2 + 1, config.down),
      up_(config.seed * 2 + 2, config.up) {}

Expected<std::unique_ptr<EvalSession>> EvalSession::create(vk::Context& context, const SceneStore& scene,
                                                           const CodecParams& params, const EvalSessionConfig& config) {
  if (!(config.display_hz > 0.0) || !(config.host_tick_s > 0.0))
    return Error{"EvalSession: display_hz and host_tick_s must be > 0"};
  std::unique_ptr<EvalSession> s(new EvalSession(scene, params, config));
  client::ClientRuntimeConfig rc;
  rc.state.capacity = config.budget;
  rc.state.name = "gauss-eval";
  rc.state.publisher.mode = config.mode;
  // A fixed allowance: the client's measured (wall-clock) frame cost then never changes
  // what a frame publishes, so publication is a function of virtual time alone.
  rc.state.publisher.allowance_initial = config.allowance;
  rc.state.publisher.allowance_min = config.allowance;
  rc.state.publisher.allowance_max = config.allowance;
  rc.state.publisher.display_period_s = 1.0 / config.display_hz;
  rc.max_width = config.width;
  rc.max_height = config.height;
  rc.highlight_query = false;  // images with a query are measured, not tinted
  rc.publication_thread = rc.publication_lockstep = config.publication_thread;
  EvalSession* self = s.get();
  rc.clock = [self] { return self->now_; };
  auto rt = client::ClientRuntime::create(context, rc);
  if (!rt) return Error{"EvalSession: " + rt.message()};
  s->client_ = std::move(*rt);
  const msg::Hello hello = s->client_->with_state([](const ClientState& st) { return st.hello(); });
  if (auto st = s->send(s->to_host_, s->up_, wire::Message{hello}, 0.0); !st) return st.error();
  return s;
}

Status EvalSession::send(std::deque<InFlight>& queue, sim::Link& link, const wire::Message& m, double t) {
  auto bytes = wire::encode(m);
  if (!bytes) return Error{"EvalSession: encoding a message: " + bytes.message()};
  const double at = link.send(t, bytes->size());
  if (&queue == &to_client_) {
    ++messages_down_;
    bytes_down_ += bytes->size();
  }
  queue.push_back({at, std::move(*bytes)});
  return Ok{};
}

Status EvalSession::host_until(double t) {
  while (next_tick_ <= t) {
    const double tick = next_tick_;
    while (!to_host_.empty() && to_host_.front().at <= tick) {
      auto m = wire::decode(to_host_.front().bytes);
      to_host_.pop_front();
      if (!m) return Error{"EvalSession: the host could not decode a client message: " + m.message()};
      for (const wire::Message& reply : host_.on_message(*m, *scene_, tick))
        if (auto st = send(to_client_, down_, reply, tick); !st) return st;
    }
    auto out = host_.tick(*scene_, tick);
    if (!out) return Error{"EvalSession: host tick at t = " + std::to_string(tick) + ": " + out.message()};
    for (const wire::Message& m : *out)
      if (auto st = send(to_client_, down_, m, tick); !st) return st;
    // Tick k at k * period (no accumulated rounding).
    next_tick_ = std::floor(tick / config_.host_tick_s + 1.5) * config_.host_tick_s;
  }
  return Ok{};
}

Status EvalSession::deliver_until(double t) {
  while (!to_client_.empty() && to_client_.front().at <= t) {
    auto m = wire::decode(to_client_.front().bytes);
    to_client_.pop_front();
    if (!m) return Error{"EvalSession: the client could not decode a host message: " + m.message()};
    client_->deliver(*m);
  }
  return Ok{};
}

Expected<client::DisplayFrameStats> EvalSession::step(const Camera& view) {
  return step_views(std::span<const Camera>(&view, 1));
}

Expected<client::DisplayFrameStats> EvalSession::step_views(std::span<const Camera> views) {
  const double t = now_;
  if (auto st = host_until(t); !st) return st.error();
  if (auto st = deliver_until(t); !st) return st.error();
  auto f = client_->frame(views);
  if (!f) return Error{"EvalSession: client frame at t = " + std::to_string(t) + ": " + f.message()};
  for (const wire::Message& m : client_->take_outgoing())
    if (auto st = send(to_host_, up_, m, t); !st) return st.error();
  ++frame_count_;
  now_ = static_cast<double>(frame_count_) / config_.display_hz;
  return f;
}

bool EvalSession::in_sync() {
  if (!to_client_.empty()) return false;
  // The sent set and its records change only with a host message, unless the scene is
  // edited between ticks (gauss-eval does so only in the live-latency run, never during a
  // settle), so the checksum is recomputed only after one.
  if (sent_checksum_at_ != messages_down_) {
    sent_checksum_ = host_.sent_checksum();
    sent_checksum_at_ = messages_down_;
  }
  return client_->with_state([&](const ClientState& s) {
    return s.welcomed() && s.desired().pending().empty() && s.published_checksum() == sent_checksum_;
  });
}

Expected<SettleResult> EvalSession::settle(const Camera& view, double timeout_s, double quiet_s,
                                           const std::function<void(const client::DisplayFrameStats&)>& on_frame) {
  return settle_views(std::span<const Camera>(&view, 1), timeout_s, quiet_s, on_frame);
}

Expected<SettleResult> EvalSession::settle_views(std::span<const Camera> views, double timeout_s, double quiet_s,
                                                 const std::function<void(const client::DisplayFrameStats&)>& on_frame) {
  SettleResult r;
  r.start_s = now_;
  double sync_since = -1.0;
  while (now_ - r.start_s <= timeout_s) {
    const double t = now_;
    const std::uint64_t sent_before = messages_down_;
    auto f = step_views(views);
    if (!f) return f.error();
    ++r.frames;
    r.slot_writes += f->publish.slot_writes();
    r.frame_cpu_ms.push_back(f->cpu_ms);
    if (on_frame) on_frame(*f);
    // In sync after this frame, and the host sent nothing new during it.
    const bool sync = f->publish.slot_writes() == 0 && f->pending == 0 && messages_down_ == sent_before && in_sync();
    if (!sync) {
      sync_since = -1.0;
      continue;
    }
    if (sync_since < 0.0) sync_since = t;
    if (r.in_sync_s < 0.0) r.in_sync_s = t - r.start_s;
    if (t - sync_since >= quiet_s) {
      r.converged = true;
      r.converged_s = sync_since - r.start_s;
      break;
    }
  }
  return r;
}

std::uint64_t EvalSession::resident_on(std::span<const ObjectId> targets) {
  return client_->with_state([&](const ClientState& s) { return s.count_resident(targets); });
}

std::vector<std::pair<std::uint32_t, GaussianId>> EvalSession::slot_ids() {
  return client_->with_state([](const ClientState& s) {
    std::vector<std::pair<std::uint32_t, GaussianId>> out;
    const SlotTable& slots = s.slots();
    for (std::uint32_t k = 0; k < slots.capacity(); ++k) {
      GaussianId id{0};
      if (slots.occupant(SlotIndex{k}, id)) out.emplace_back(k, id);
    }
    return out;
  });
}

Status EvalSession::load_sent_set(render::SplatRenderer& renderer) {
  if (renderer.capacity() < config_.budget)
    return Error{"load_sent_set: renderer of " + std::to_string(renderer.capacity()) + " slots < M = " +
                 std::to_string(config_.budget)};
  const auto held = slot_ids();
  const std::vector<GaussianId>& sent = host_.sent_ids();  // sorted
  if (held.size() != sent.size())
    return Error{"load_sent_set: the client holds " + std::to_string(held.size()) + " Gaussians, the host sent " +
                 std::to_string(sent.size())};
  auto record_of = [&](GaussianId id) -> Expected<Gaussian> {
    if (!std::binary_search(sent.begin(), sent.end(), id))
      return Error{"load_sent_set: the client holds Gaussian " + std::to_string(to_underlying(id)) +
                   ", which the host did not send"};
    std::optional<Gaussian> g = host_.sent_record(id);
    if (!g) return Error{"load_sent_set: the host has no record of Gaussian " + std::to_string(to_underlying(id))};
    return *g;
  };
  if (auto st = write_at_slots(renderer, held, record_of); !st) return st;
  renderer.clear_mesh();
  for (const SurfaceChunk& chunk : scene_->surface_chunks())
    if (auto st = renderer.set_mesh_chunk(chunk.chunk_id, chunk.mesh); !st) return st;
  return Ok{};
}

}  // namespace gauss::eval_app
