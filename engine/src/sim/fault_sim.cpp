#include "gauss/engine/sim_faults.h"

#include <cmath>

#include "gauss/engine/sim.h"
#include "stream/splitmix.h"

namespace gauss::sim {

namespace {

// splitmix64 stream: the whole schedule derives from the seed, identically everywhere.
struct Rng {
  std::uint64_t s;
  std::uint64_t next() { return splitmix64_next(s); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit_double(next()); }
  std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next() % n); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
};

glm::vec4 yaw_quat(double yaw) {
  // Rotation about the world y axis (up in the synthetic room; OpenCV head frame).
  return glm::vec4(static_cast<float>(std::cos(yaw * 0.5)), 0.0f, static_cast<float>(std::sin(yaw * 0.5)), 0.0f);
}

}  // namespace

std::string FaultSeedReport::describe() const {
  return "seed " + std::to_string(seed) + ": " + std::to_string(clients) + " clients, " + std::to_string(faults) +
         " faults (" + std::to_string(crashes) + " crashes, " + std::to_string(disconnects) + " disconnects, " +
         std::to_string(query_floods) + " query floods, " + std::to_string(stalls) + " stalls, " +
         std::to_string(arrival_overflows) + " arrival overflows), " + std::to_string(frames) +
         " frames, converged at t=" + std::to_string(converged_at_s);
}

Expected<FaultSeedReport> run_fault_seed(std::uint64_t seed) {
  Rng rng{seed * 0x2545f4914f6cdd1dull + 17};
  FaultSeedReport rep;
  rep.seed = seed;
  SimConfig cfg;
  cfg.seed = seed;
  cfg.scene.seed = seed;
  cfg.scene.variant = static_cast<int>(rng.below(4));
  cfg.scene.target_gaussians = 400 + rng.below(600);
  cfg.scene.epochs = 3 + static_cast<int>(rng.below(5));
  cfg.scene.cameras_per_epoch = 1;
  cfg.scene.converge_epochs = 1 + static_cast<int>(rng.below(3));
  cfg.epoch_period_s = rng.uniform(0.05, 0.2);
  cfg.host_tick_s = rng.uniform(0.01, 0.05);
  cfg.surface_every = 1 + static_cast<int>(rng.below(3));
  cfg.host.query_burst = 1 + rng.below(4);
  cfg.host.queries_per_s = rng.uniform(1.0, 8.0);
  const std::uint32_t n_clients = 1 + rng.below(2);
  rep.clients = n_clients;
  auto random_link = [&rng]() {
    LinkConditions l;
    l.latency_s = rng.uniform(0.001, 0.03);
    l.bandwidth_bps = rng.uniform(5e6, 100e6);
    l.loss = rng.chance(0.5) ? rng.uniform(0.0, 0.1) : 0.0;
    return l;
  };
  for (std::uint32_t c = 0; c < n_clients; ++c) {
    ClientSpec s;
    s.client.capacity = 16 + rng.below(300);
    s.client.name = "c" + std::to_string(c);
    s.client.publisher.mode = rng.chance(0.5) ? PublishMode::Immediate : PublishMode::Progressive;
    s.client.publisher.allowance_min = 1 + rng.below(20);
    s.client.publisher.allowance_initial = s.client.publisher.allowance_min + rng.below(50);
    s.client.publisher.allowance_max = s.client.publisher.allowance_initial + rng.below(200);
    s.client.publisher.age_escape_s = rng.uniform(0.05, 1.0);
    s.client.publisher.escape_quota = rng.below(20);
    if (rng.chance(0.5)) {  // ranking that lags behind the arrivals
      s.client.publisher.rescore_per_frame = 1 + rng.below(64);
      s.client.publisher.rank_allowances = rng.below(4);
    }
    s.client.range_merge_gap = rng.below(4);
    s.client.arrival_slack = rng.chance(0.5) ? rng.below(64) : DesiredState::kArrivalSlack;
    const double hz[] = {60.0, 72.0, 90.0, 120.0};
    s.display_hz = hz[rng.below(4)];
    s.down = random_link();
    s.up = random_link();
    cfg.clients.push_back(s);
  }
  auto sim = Simulation::create(cfg);
  if (!sim) return Error{"seed " + std::to_string(seed) + ": " + sim.message()};

  const double duration = rng.uniform(0.6, 1.2);
  const double step = 0.05;
  std::vector<bool> link_faulted(n_clients, false);
  for (double t = step; t < duration; t += step) {
    if (Status s = sim->run_until(t); !s) return s.error();
    if (!rng.chance(0.25)) continue;
    const std::uint32_t c = rng.below(n_clients);
    ++rep.faults;
    switch (rng.below(9)) {
      case 0: {  // latency spike
        LinkConditions d = cfg.clients[c].down;
        d.latency_s *= rng.uniform(5.0, 20.0);
        sim->set_links(c, d, cfg.clients[c].up);
        link_faulted[c] = true;
        break;
      }
      case 1: {  // bandwidth drop
        LinkConditions d = cfg.clients[c].down;
        d.bandwidth_bps /= rng.uniform(5.0, 50.0);
        sim->set_links(c, d, cfg.clients[c].up);
        link_faulted[c] = true;
        break;
      }
      case 2: {  // loss burst, both directions
        LinkConditions d = cfg.clients[c].down, u = cfg.clients[c].up;
        d.loss = u.loss = rng.uniform(0.2, 0.5);
        sim->set_links(c, d, u);
        link_faulted[c] = true;
        break;
      }
      case 3:
        sim->crash(c, rng.uniform(0.02, 0.3));
        ++rep.crashes;
        break;
      case 4:
        sim->disconnect(c, rng.uniform(0.02, 0.3));
        ++rep.disconnects;
        break;
      case 5:
        if (Status s = sim->epoch_burst(2 + static_cast<int>(rng.below(3))); !s) return s.error();
        break;
      case 6: {  // query flood: valid, unknown and clearing queries back to back
        ++rep.query_floods;
        const auto& objs = sim->scene().objects();
        const std::uint32_t n = 5 + rng.below(30);
        for (std::uint32_t k = 0; k < n; ++k) {
          msg::Query q;
          const std::uint32_t kind = rng.below(4);
          if (kind == 0 || objs.empty()) {
            q.kind = msg::QueryKind::Clear;
          } else if (kind == 1) {
            q.kind = msg::QueryKind::ClassText;
            q.text = objs[rng.below(static_cast<std::uint32_t>(objs.size()))].label;
            if (q.text.empty()) q.text = "nothing-like-this";
            q.rho = static_cast<float>(rng.uniform(0.0, 1.0));
          } else if (kind == 2) {
            q.kind = msg::QueryKind::Instance;
            q.instance = objs[rng.below(static_cast<std::uint32_t>(objs.size()))].id;
            q.rho = static_cast<float>(rng.uniform(0.0, 1.0));
          } else {
            q.kind = msg::QueryKind::Instance;
            q.instance = ObjectId{100000 + static_cast<std::int32_t>(rng.below(100))};  // unknown
            q.rho = 0.5f;
          }
          sim->query(c, q);
        }
        break;
      }
      case 7: {  // display stall, with the host busy meanwhile
        sim->stall(c, rng.uniform(0.1, 1.0));
        if (Status s = sim->epoch_burst(1 + static_cast<int>(rng.below(4))); !s) return s.error();
        ++rep.stalls;
        break;
      }
      default: {  // far pose jump anywhere in the room, any heading
        // Braced: the three draws happen in this order with every compiler (a seed must
        // reproduce exactly; function arguments have no evaluation order).
        const glm::vec3 p{static_cast<float>(rng.uniform(-4.0, 4.0)), static_cast<float>(rng.uniform(0.5, 2.5)),
                          static_cast<float>(rng.uniform(-4.0, 4.0))};
        sim->set_pose(c, p, yaw_quat(rng.uniform(0.0, 6.2831853)));
        break;
      }
    }
    // Link faults last a few steps.
    for (std::uint32_t k = 0; k < n_clients; ++k)
      if (link_faulted[k] && rng.chance(0.3)) {
        sim->set_links(k, cfg.clients[k].down, cfg.clients[k].up);
        link_faulted[k] = false;
      }
  }
  // Faults over: clean links, no more epochs; everyone must converge exactly.
  for (std::uint32_t k = 0; k < n_clients; ++k) sim->set_links(k, cfg.clients[k].down, cfg.clients[k].up);
  sim->stop_scene();
  if (Status s = sim->run_until_converged(duration + 30.0); !s) return s.error();
  rep.converged_at_s = sim->now();
  for (std::uint32_t k = 0; k < n_clients; ++k) {
    rep.frames += sim->frames(k);
    if (const HostSession* hs = sim->session(k)) rep.rejected_queries += hs->stats().rejected_queries;
    if (const ClientState* cs = sim->client(k)) rep.arrival_overflows += cs->desired().stats().arrival_overflows;
  }
  return rep;
}

}  // namespace gauss::sim
