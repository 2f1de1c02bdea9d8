#pragma once
// Seeded fault simulation in the spirit of deterministic simulation testing: one seed
// fixes a small world (clients, budgets, publication modes, display rates, links) and
// a schedule of faults: latency spikes, bandwidth drops, loss bursts, client crashes
// and restarts, disconnects and reconnects, host epoch bursts, query floods, display
// stalls and far pose jumps. The simulation checks its invariants at every frame and
// after every batch; at the end, with the faults over, every client must converge exactly
// (published = desired = the host's intended set). A failing seed reproduces exactly
// from its number: run_fault_seed(seed) again (tests/engine/test_sim_faults.cpp reads
// GAUSS_SIM_SEED; scripts/sim-nightly runs many).
#include <cstdint>
#include <string>

#include "gauss/engine/result.h"

namespace gauss::sim {

struct FaultSeedReport {
  std::uint64_t seed{0};
  std::uint32_t clients{0};
  std::uint32_t faults{0};            // fault events injected
  std::uint32_t crashes{0};
  std::uint32_t disconnects{0};
  std::uint32_t query_floods{0};
  std::uint32_t stalls{0};
  std::uint64_t arrival_overflows{0};  // of the clients' final states (a crash starts a fresh one)
  std::uint64_t rejected_queries{0};  // by the host's rate limit, summed over sessions seen at the end
  std::uint64_t frames{0};
  double converged_at_s{0.0};         // virtual time when every client had converged
  std::string describe() const;
};

// Runs one seed. Error: the first invariant violation or a failure to converge, with
// the seed in the message.
Expected<FaultSeedReport> run_fault_seed(std::uint64_t seed);

}  // namespace gauss::sim
