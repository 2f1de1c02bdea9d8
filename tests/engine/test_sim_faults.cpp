// Seeded fault simulation: >= 1,000 seeds, invariants at every frame, exact final
// state. A failing seed reproduces from its number:
//   GAUSS_SIM_SEED=1234 build/tests/engine_sim_faults
// scripts/sim-nightly runs many more (GAUSS_SIM_SEEDS=first:count).
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "gauss/engine/sim_faults.h"

using namespace gauss::sim;

namespace {

struct Range {
  std::uint64_t first{1};
  std::uint64_t count{1000};
};

Range seeds_from_env() {
  Range r;
  if (const char* one = std::getenv("GAUSS_SIM_SEED"); one && *one) {
    r.first = std::strtoull(one, nullptr, 10);
    r.count = 1;
  } else if (const char* many = std::getenv("GAUSS_SIM_SEEDS"); many && *many) {
    const std::string s(many);
    const auto colon = s.find(':');
    r.first = std::strtoull(s.substr(0, colon).c_str(), nullptr, 10);
    if (colon != std::string::npos) r.count = std::strtoull(s.substr(colon + 1).c_str(), nullptr, 10);
  }
  return r;
}

}  // namespace

TEST(SimFaults, EverySeedKeepsInvariantsAndConvergesExactly) {
  const Range r = seeds_from_env();
  std::uint64_t failures = 0, crashes = 0, disconnects = 0, floods = 0, rejected = 0, frames = 0, stalls = 0,
                overflows = 0;
  for (std::uint64_t seed = r.first; seed < r.first + r.count; ++seed) {
    auto rep = run_fault_seed(seed);
    if (!rep) {
      ++failures;
      ADD_FAILURE() << rep.message() << "\n  reproduce: GAUSS_SIM_SEED=" << seed << " " << "engine_sim_faults";
      if (failures >= 10) break;
      continue;
    }
    crashes += rep->crashes;
    disconnects += rep->disconnects;
    floods += rep->query_floods;
    stalls += rep->stalls;
    overflows += rep->arrival_overflows;
    rejected += rep->rejected_queries;
    frames += rep->frames;
    if (r.count == 1) std::printf("%s\n", rep->describe().c_str());
  }
  std::printf("seeds %llu..%llu: %llu frames checked, %llu crashes, %llu disconnects, %llu query floods (%llu queries "
              "rate-limited), %llu stalls (%llu arrival overflows)\n",
              static_cast<unsigned long long>(r.first), static_cast<unsigned long long>(r.first + r.count - 1),
              static_cast<unsigned long long>(frames), static_cast<unsigned long long>(crashes),
              static_cast<unsigned long long>(disconnects), static_cast<unsigned long long>(floods),
              static_cast<unsigned long long>(rejected), static_cast<unsigned long long>(stalls),
              static_cast<unsigned long long>(overflows));
  if (r.count >= 100) {
    // The schedule really exercised the faults it claims to.
    EXPECT_GT(crashes, 0u);
    EXPECT_GT(disconnects, 0u);
    EXPECT_GT(floods, 0u);
    EXPECT_GT(rejected, 0u);
    EXPECT_GT(stalls, 0u);
    EXPECT_GT(overflows, 0u);  // a stall that made the publisher rescan
  }
}

TEST(SimFaults, ASeedReproducesExactly) {
  auto a = run_fault_seed(424242);
  auto b = run_fault_seed(424242);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  EXPECT_EQ(a->describe(), b->describe());
  EXPECT_EQ(a->frames, b->frames);
  EXPECT_EQ(a->converged_at_s, b->converged_at_s);
}
