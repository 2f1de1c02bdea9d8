#include "gauss/engine/sim.h"

#include <algorithm>
#include <map>
#include <queue>
#include <string>

#include <glm/gtc/quaternion.hpp>

namespace gauss::sim {

namespace {

enum class Kind : std::uint8_t { HostEpoch, HostTick, Frame, Pose, ToClient, ToHost, Connect, Restart };

struct Event {
  double t{0.0};
  std::uint64_t seq{0};
  Kind kind{Kind::HostTick};
  std::uint32_t client{0};
  std::uint64_t gen{0};  // connection generation the message belongs to
  std::shared_ptr<std::vector<std::uint8_t>> bytes;
  bool operator>(const Event& o) const { return t != o.t ? t > o.t : seq > o.seq; }
};

std::string cname(std::uint32_t i) { return "client " + std::to_string(i); }

}  // namespace

struct Simulation::Impl {
  struct Client {
    ClientSpec spec;
    std::optional<ClientState> state;
    std::optional<HostSession> session;
    Link down{0}, up{0};
    std::uint64_t gen{0};
    bool connected{false};
    std::uint64_t frame{0};
    double stalled_until{0.0};  // no frame before this time (Simulation::stall)
    glm::vec3 position{0.0f, 1.6f, 0.0f};
    glm::vec4 rotation{1.0f, 0.0f, 0.0f, 0.0f};
    std::map<std::uint64_t, std::uint64_t> expected;  // batch id -> host's intended desired checksum
  };

  SimConfig cfg;
  std::optional<SyntheticScene> synth;
  SceneStore store{256};
  TriangleMesh room_mesh;
  bool scene_stopped{false};
  int epochs_made{0};
  double t{0.0};
  std::uint64_t seq{0};
  std::uint32_t next_client_id{1};
  std::priority_queue<Event, std::vector<Event>, std::greater<Event>> queue;
  std::vector<Client> clients;
  std::function<void(const FrameSample&)> on_frame;
  CodecParams params;

  void push(double at, Kind k, std::uint32_t c = 0, std::uint64_t gen = 0,
            std::shared_ptr<std::vector<std::uint8_t>> bytes = nullptr) {
    queue.push(Event{at, seq++, k, c, gen, std::move(bytes)});
  }

  // Encodes and sends one message over a client's link; delivery is an event.
  Status send(std::uint32_t c, const wire::Message& m, bool to_client) {
    auto bytes = wire::encode(m);
    if (!bytes) return Error{cname(c) + ": encoding " + msg::to_string(wire::type_of(m)) + " failed: " + bytes.message()};
    Client& cl = clients[c];
    Link& link = to_client ? cl.down : cl.up;
    const double at = link.send(t, bytes->size());
    push(at, to_client ? Kind::ToClient : Kind::ToHost, c, cl.gen,
         std::make_shared<std::vector<std::uint8_t>>(std::move(*bytes)));
    return Ok{};
  }

  Status flush_client(std::uint32_t c) {
    Client& cl = clients[c];
    if (!cl.state || !cl.connected) return Ok{};
    for (const auto& m : cl.state->take_outgoing())
      if (Status s = send(c, m, false); !s) return s;
    return Ok{};
  }

  void connect(std::uint32_t c) {
    Client& cl = clients[c];
    drop(c);  // a new connection: the old one's traffic and session are gone
    cl.connected = true;
    cl.down.reset(t);
    cl.up.reset(t);
    (void)send(c, cl.state->hello(), false);
    cl.state->send_pose(pose_of(cl));
    (void)flush_client(c);
  }

  void drop(std::uint32_t c) {
    Client& cl = clients[c];
    ++cl.gen;  // in-flight messages of the old connection are lost
    cl.connected = false;
    cl.session.reset();  // a client gone mid-batch costs the host nothing more
    cl.expected.clear();
  }

  msg::HeadPose pose_of(const Client& cl) const {
    msg::HeadPose p;
    p.client_time_us = static_cast<std::uint64_t>(t * 1e6);
    p.position = cl.position;
    p.rotation = cl.rotation;
    return p;
  }

  Status produce_epoch() {
    if (scene_stopped || synth->finished()) return Ok{};
    if (Status s = synth->produce(store); !s) return Error{"sim: scene epoch failed: " + s.message()};
    ++epochs_made;
    if (cfg.surface_every > 0 && epochs_made % cfg.surface_every == 0 && !room_mesh.indices.empty()) {
      // A surface-only epoch: one slice of the room mesh as chunk (epoch % 8).
      const std::size_t tris = room_mesh.indices.size() / 3;
      const std::size_t per = 64;
      const std::size_t first = (static_cast<std::size_t>(epochs_made) * per) % tris;
      SurfaceChunk chunk;
      chunk.chunk_id = static_cast<std::uint32_t>(epochs_made % 8);
      for (std::size_t k = first; k < std::min(tris, first + per); ++k)
        for (int v = 0; v < 3; ++v) {
          const std::uint32_t src = room_mesh.indices[k * 3 + static_cast<std::size_t>(v)];
          chunk.mesh.indices.push_back(static_cast<std::uint32_t>(chunk.mesh.positions.size()));
          chunk.mesh.positions.push_back(room_mesh.positions[src]);
          chunk.mesh.colors.push_back(room_mesh.colors[src]);
        }
      if (Status s = store.begin_next_epoch(); !s) return s;
      if (Status s = store.set_surface_chunk(std::move(chunk)); !s) return Error{"sim: surface chunk: " + s.message()};
      if (Status s = store.commit_epoch(); !s) return s;
    }
    return Ok{};
  }

  Status host_tick() {
    for (std::uint32_t c = 0; c < clients.size(); ++c) {
      Client& cl = clients[c];
      if (!cl.session || !cl.connected) continue;
      auto out = cl.session->tick(store, t);
      if (!out) return Error{cname(c) + ": " + out.message()};
      for (const auto& m : *out) {
        if (const auto* b = std::get_if<msg::EditBatchMsg>(&m); b && cfg.check_coalescing)
          cl.expected[b->batch_id] = cl.session->sent_checksum();
        if (Status s = send(c, m, true); !s) return s;
      }
    }
    return Ok{};
  }

  Status to_host(const Event& e) {
    Client& cl = clients[e.client];
    if (e.gen != cl.gen || !cl.connected) return Ok{};  // old connection: lost
    auto m = wire::decode(*e.bytes);
    if (!m) return Error{cname(e.client) + ": host could not decode a client message: " + m.message()};
    if (!cl.session) {
      if (!std::holds_alternative<msg::Hello>(*m)) return Ok{};  // the transport drops pre-hello traffic
      cl.session.emplace(next_client_id++, cfg.seed, params, cfg.host);
    }
    for (const auto& reply : cl.session->on_message(*m, store, t))
      if (Status s = send(e.client, reply, true); !s) return s;
    return Ok{};
  }

  Status to_client(const Event& e) {
    Client& cl = clients[e.client];
    if (e.gen != cl.gen || !cl.connected || !cl.state) return Ok{};
    auto m = wire::decode(*e.bytes);
    if (!m) return Error{cname(e.client) + ": client could not decode a host message: " + m.message()};
    Status s = cl.state->on_message(*m, t);
    if (!s) return Error{cname(e.client) + ": host message rejected: " + s.message()};
    if (const auto* b = std::get_if<msg::EditBatchMsg>(&*m); b && cfg.check_coalescing) {
      auto it = cl.expected.find(b->batch_id);
      if (it != cl.expected.end()) {
        if (cl.state->desired().desired_checksum() != it->second)
          return Error{cname(e.client) + ": after batch " + std::to_string(b->batch_id) + " (epoch " +
                       std::to_string(to_underlying(b->epoch)) + ") the desired set differs from the host's intended set"};
        cl.expected.erase(cl.expected.begin(), std::next(it));
      }
    }
    return flush_client(e.client);
  }

  Status frame(std::uint32_t c) {
    Client& cl = clients[c];
    push(t + 1.0 / cl.spec.display_hz, Kind::Frame, c);
    if (!cl.state || t < cl.stalled_until) return Ok{};
    const glm::quat q(cl.rotation[0], cl.rotation[1], cl.rotation[2], cl.rotation[3]);
    ViewState view{cl.position, glm::normalize(q * glm::vec3(0.0f, 0.0f, 1.0f))};
    auto r = cl.state->frame(view, t, cl.frame);
    if (!r) return Error{cname(c) + " frame " + std::to_string(cl.frame) + ": " + r.message()};
    const double cost = cfg.cost.base_s + cfg.cost.per_write_s * r->publish.slot_writes() +
                        cfg.cost.per_range_s * static_cast<double>(r->ranges.size());
    cl.state->report_frame_cost(cost);
    cl.state->frame_rendered(t, cl.frame);
    if (cfg.check_every_frame) {
      if (Status s = cl.state->check(); !s)
        return Error{cname(c) + " frame " + std::to_string(cl.frame) + " (t=" + std::to_string(t) + "): " + s.message()};
    }
    if (on_frame) {
      FrameSample f;
      f.t = t;
      f.client = c;
      f.frame = cl.frame;
      f.publish = r->publish;
      f.ranges = r->ranges.size();
      f.published = cl.state->slots().size();
      f.desired = cl.state->desired().desired_count();
      f.pending = cl.state->desired().pending_count();
      f.cost_s = cost;
      on_frame(f);
    }
    ++cl.frame;
    return flush_client(c);
  }

  Status step(const Event& e) {
    t = e.t;
    switch (e.kind) {
      case Kind::HostEpoch:
        push(t + cfg.epoch_period_s, Kind::HostEpoch);
        return produce_epoch();
      case Kind::HostTick:
        push(t + cfg.host_tick_s, Kind::HostTick);
        return host_tick();
      case Kind::Frame: return frame(e.client);
      case Kind::Pose: {
        Client& cl = clients[e.client];
        push(t + 1.0 / cl.spec.pose_hz, Kind::Pose, e.client);
        if (cl.state && cl.connected) cl.state->send_pose(pose_of(cl));
        return flush_client(e.client);
      }
      case Kind::ToClient: return to_client(e);
      case Kind::ToHost: return to_host(e);
      case Kind::Connect:
        if (clients[e.client].state && !clients[e.client].connected) connect(e.client);
        return Ok{};
      case Kind::Restart: {
        Client& cl = clients[e.client];
        auto st = ClientState::create(e.client, cl.spec.client);
        if (!st) return st.error();
        cl.state.emplace(std::move(*st));
        cl.frame = 0;
        connect(e.client);
        return Ok{};
      }
    }
    return Ok{};
  }

  Status converged(std::uint32_t c) const {
    const Client& cl = clients[c];
    if (!cl.state) return Error{cname(c) + ": crashed, not restarted"};
    if (!cl.connected || !cl.session || !cl.session->accepted()) return Error{cname(c) + ": not connected"};
    if (cl.state->desired().pending_count() != 0)
      return Error{cname(c) + ": " + std::to_string(cl.state->desired().pending_count()) + " edits pending"};
    if (cl.state->desired().desired_count() != cl.session->sent_ids().size())
      return Error{cname(c) + ": desired " + std::to_string(cl.state->desired().desired_count()) + " != host's " +
                   std::to_string(cl.session->sent_ids().size())};
    const std::uint64_t d = cl.state->desired().desired_checksum();
    if (cl.state->published_checksum() != d) return Error{cname(c) + ": published set differs from desired set"};
    if (cl.session->sent_checksum() != d) return Error{cname(c) + ": desired set differs from the host's intended set"};
    return Ok{};
  }
};

Simulation::Simulation(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;
Simulation::~Simulation() = default;

Expected<Simulation> Simulation::create(SimConfig config) {
  if (config.clients.empty()) return Error{"sim: no clients"};
  if (!(config.epoch_period_s > 0.0) || !(config.host_tick_s > 0.0)) return Error{"sim: epoch period and host tick must be > 0"};
  auto impl = std::make_unique<Impl>();
  impl->cfg = config;
  auto synth = SyntheticScene::create(config.scene);
  if (!synth) return Error{"sim: " + synth.message()};
  impl->synth.emplace(std::move(*synth));
  impl->room_mesh = impl->synth->surface_mesh();
  // Codec ranges for the whole session, from the room's extent (the scene grows
  // inside it), padded; SH degree of the synthetic scene.
  impl->params.box.min = impl->synth->room_min() - glm::vec3(0.5f);
  impl->params.box.max = impl->synth->room_max() + glm::vec3(0.5f);
  impl->params.sh_degree = 1;
  if (Status s = validate_codec_params(impl->params); !s) return Error{"sim: codec params: " + s.message()};
  for (std::uint32_t c = 0; c < config.clients.size(); ++c) {
    const ClientSpec& spec = config.clients[c];
    if (!(spec.display_hz > 0.0) || !(spec.pose_hz > 0.0)) return Error{"sim: " + cname(c) + ": rates must be > 0"};
    auto st = ClientState::create(c, spec.client);
    if (!st) return Error{"sim: " + st.message()};
    Impl::Client cl;
    cl.spec = spec;
    cl.state.emplace(std::move(*st));
    cl.down = Link(config.seed * 1000 + c * 2 + 1, spec.down);
    cl.up = Link(config.seed * 1000 + c * 2 + 2, spec.up);
    impl->clients.push_back(std::move(cl));
  }
  Impl& m = *impl;
  if (Status s = m.produce_epoch(); !s) return s.error();
  m.push(m.cfg.epoch_period_s, Kind::HostEpoch);
  m.push(0.0, Kind::HostTick);
  for (std::uint32_t c = 0; c < m.clients.size(); ++c) {
    m.connect(c);
    // Stagger displays a little so clients do not tick in lockstep.
    m.push(0.001 * (c + 1), Kind::Frame, c);
    m.push(0.1 + 0.003 * c, Kind::Pose, c);
  }
  return Simulation(std::move(impl));
}

double Simulation::now() const { return impl_->t; }

Status Simulation::run_until(double t) {
  while (!impl_->queue.empty() && impl_->queue.top().t <= t) {
    Event e = impl_->queue.top();
    impl_->queue.pop();
    if (Status s = impl_->step(e); !s) return Error{"sim seed " + std::to_string(impl_->cfg.seed) + ": " + s.message()};
  }
  impl_->t = std::max(impl_->t, t);
  return Ok{};
}

Status Simulation::run_until_converged(double max_t) {
  for (;;) {
    Status all = check_converged();
    if (all) return Ok{};
    if (impl_->t >= max_t) return Error{"sim seed " + std::to_string(impl_->cfg.seed) + ": not converged by t=" + std::to_string(max_t) + ": " + all.message()};
    if (Status s = run_until(std::min(max_t, impl_->t + 0.05)); !s) return s;
  }
}

void Simulation::set_pose(std::uint32_t c, glm::vec3 position, glm::vec4 rotation) {
  auto& cl = impl_->clients.at(c);
  cl.position = position;
  cl.rotation = rotation;
}

std::uint32_t Simulation::query(std::uint32_t c, msg::Query q) {
  auto& cl = impl_->clients.at(c);
  if (!cl.state) return 0;
  const std::uint32_t id = cl.state->send_query(std::move(q));
  (void)impl_->flush_client(c);
  return id;
}

void Simulation::crash(std::uint32_t c, double restart_after_s) {
  auto& cl = impl_->clients.at(c);
  impl_->drop(c);
  cl.state.reset();
  impl_->push(impl_->t + restart_after_s, Kind::Restart, c);
}

void Simulation::disconnect(std::uint32_t c, double reconnect_after_s) {
  auto& cl = impl_->clients.at(c);
  if (!cl.connected) return;
  impl_->drop(c);
  if (cl.state) cl.state->on_disconnect();
  impl_->push(impl_->t + reconnect_after_s, Kind::Connect, c);
}

void Simulation::stall(std::uint32_t c, double seconds) {
  auto& cl = impl_->clients.at(c);
  cl.stalled_until = std::max(cl.stalled_until, impl_->t + seconds);
}

void Simulation::set_links(std::uint32_t c, const LinkConditions& down, const LinkConditions& up) {
  auto& cl = impl_->clients.at(c);
  cl.down.set_conditions(down);
  cl.up.set_conditions(up);
}

Status Simulation::epoch_burst(int n) {
  for (int i = 0; i < n; ++i)
    if (Status s = impl_->produce_epoch(); !s) return s;
  return Ok{};
}

void Simulation::stop_scene() { impl_->scene_stopped = true; }

Status Simulation::check_converged() const {
  for (std::uint32_t c = 0; c < impl_->clients.size(); ++c)
    if (Status s = impl_->converged(c); !s) return s;
  return Ok{};
}

std::size_t Simulation::client_count() const { return impl_->clients.size(); }
const ClientState* Simulation::client(std::uint32_t i) const {
  const auto& s = impl_->clients.at(i).state;
  return s ? &*s : nullptr;
}
ClientState* Simulation::client(std::uint32_t i) {
  auto& s = impl_->clients.at(i).state;
  return s ? &*s : nullptr;
}
const HostSession* Simulation::session(std::uint32_t i) const {
  const auto& s = impl_->clients.at(i).session;
  return s ? &*s : nullptr;
}
const SceneStore& Simulation::scene() const { return impl_->store; }
const Link& Simulation::down_link(std::uint32_t i) const { return impl_->clients.at(i).down; }
std::uint64_t Simulation::frames(std::uint32_t i) const { return impl_->clients.at(i).frame; }
void Simulation::on_frame(std::function<void(const FrameSample&)> fn) { impl_->on_frame = std::move(fn); }

}  // namespace gauss::sim
