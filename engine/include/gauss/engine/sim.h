#pragma once
// Deterministic simulation of the whole stream: one host (an evolving synthetic scene,
// one HostSession per connection) and several clients (ClientState) in one process,
// on a virtual clock, with modelled links (sim_link.h) and a modelled display rate.
// Messages cross the links as their real wire bytes (wire::encode / wire::decode), so
// the bandwidth model is honest and the decoders run on every message. The policy code
// is exactly what the real-time path (threads + ENet in net/) runs.
//
// Everything derives from SimConfig::seed: the same config gives the same event
// order, the same figures and the same failures, bit for bit.
//
// Invariants checked (when enabled) at every display frame: published total <= M, the
// epoch barrier, no slot used twice, desired/published bookkeeping agreeing
// (ClientState::check); after every received batch: the client's desired set equals
// the host's intended set for that batch exactly (coalescing correctness, by checksum).
// At the end: published = desired = the host's intended set (check_converged).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "gauss/engine/client_state.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/sim_link.h"
#include "gauss/engine/synthetic_scene.h"

namespace gauss::sim {

// Modelled cost of one display frame on the client: render + integration work.
struct FrameCostModel {
  double base_s{0.007};         // stereo render of the published set
  double per_write_s{0.15e-6};  // CPU copy + GPU write of one slot record
  double per_range_s{2.0e-6};   // one ranged copy command
};

struct ClientSpec {
  ClientConfig client{};
  double display_hz{72.0};
  double pose_hz{10.0};  // coarse head pose rate
  LinkConditions down{};  // host -> client
  LinkConditions up{};    // client -> host
};

struct SimConfig {
  std::uint64_t seed{1};
  SyntheticSceneConfig scene{};
  double epoch_period_s{0.1};  // the host produces a scene epoch per period while epochs remain
  double host_tick_s{0.02};    // host loop: sessions select/diff at this rate
  // Every few scene epochs the host also publishes a surface chunk (its own epoch), so
  // the barrier is exercised; chunks are slices of the synthetic room's mesh.
  int surface_every{2};
  std::vector<ClientSpec> clients;
  HostSessionConfig host{};
  FrameCostModel cost{};
  bool check_every_frame{true};  // O(M) per frame
  bool check_coalescing{true};   // O(M) per batch
};

struct FrameSample {
  double t{0.0};
  std::uint32_t client{0};
  std::uint64_t frame{0};
  PublishReport publish;
  std::size_t ranges{0};
  std::size_t published{0};
  std::size_t desired{0};
  std::size_t pending{0};
  double cost_s{0.0};
};

class Simulation {
 public:
  static Expected<Simulation> create(SimConfig config);
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;
  ~Simulation();

  double now() const;
  // Runs events up to virtual time t. Fails at the first invariant violation, naming
  // the client, the frame and what broke; the seed reproduces it.
  Status run_until(double t);
  // Runs until every client has converged (check_converged passes) or max_t passes.
  Status run_until_converged(double max_t);

  // Scripted inputs, effective now().
  void set_pose(std::uint32_t client, glm::vec3 position, glm::vec4 rotation_wxyz);
  std::uint32_t query(std::uint32_t client, msg::Query q);  // returns the query id
  void crash(std::uint32_t client, double restart_after_s);        // state lost, fresh client later
  void disconnect(std::uint32_t client, double reconnect_after_s); // connection lost, state kept
  // The client's display hitches: no frame, so nothing published, for `seconds` while
  // batches keep arriving (enough of them overflow the arrival lists).
  void stall(std::uint32_t client, double seconds);
  void set_links(std::uint32_t client, const LinkConditions& down, const LinkConditions& up);
  Status epoch_burst(int n);  // the host produces n epochs at once (as far as the scene has them)
  void stop_scene();          // no further epochs

  // Converged: connected, nothing pending, published = desired = the host's intended set.
  Status check_converged() const;
  std::size_t client_count() const;
  const ClientState* client(std::uint32_t i) const;  // nullptr while crashed
  ClientState* client(std::uint32_t i);
  const HostSession* session(std::uint32_t i) const;  // nullptr while disconnected
  const SceneStore& scene() const;
  const Link& down_link(std::uint32_t i) const;
  std::uint64_t frames(std::uint32_t i) const;
  // Called after every client frame (metrics in benches and tests).
  void on_frame(std::function<void(const FrameSample&)> fn);

 private:
  struct Impl;
  explicit Simulation(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss::sim
