// Deterministic simulation: an evolving synthetic scene streamed to two clients with
// different budgets; invariants at every frame; exact final state; determinism.
#include <gtest/gtest.h>

#include "gauss/engine/sim.h"

using namespace gauss;
using namespace gauss::sim;

namespace {

SimConfig two_clients(std::uint64_t seed) {
  SimConfig cfg;
  cfg.seed = seed;
  cfg.scene.seed = seed;
  cfg.scene.target_gaussians = 3000;
  cfg.scene.epochs = 8;
  cfg.scene.cameras_per_epoch = 2;
  ClientSpec a;
  a.client.capacity = 400;
  a.client.name = "small";
  a.client.publisher.allowance_min = 20;
  a.client.publisher.allowance_initial = 50;
  a.client.publisher.allowance_max = 200;
  ClientSpec b = a;
  b.client.capacity = 1500;
  b.client.name = "large";
  b.client.publisher.mode = PublishMode::Immediate;
  b.display_hz = 90.0;
  cfg.clients = {a, b};
  return cfg;
}

}  // namespace

TEST(SimBasic, TwoClientsConvergeExactlyWithinTheirBudgets) {
  auto sim = Simulation::create(two_clients(3));
  ASSERT_TRUE(sim.ok()) << sim.message();
  std::size_t max_published[2] = {0, 0};
  sim->on_frame([&](const FrameSample& f) { max_published[f.client] = std::max(max_published[f.client], f.published); });
  ASSERT_TRUE(sim->run_until(1.5).ok());
  ASSERT_TRUE(sim->run_until_converged(10.0).ok()) << sim->check_converged().message();
  EXPECT_LE(max_published[0], 400u);
  EXPECT_LE(max_published[1], 1500u);
  EXPECT_EQ(sim->client(0)->slots().size(), sim->session(0)->sent_ids().size());
  EXPECT_GT(sim->client(0)->slots().size(), 300u);  // the budget is used
  EXPECT_GT(sim->client(1)->slots().size(), 1000u);
  EXPECT_GT(sim->client(0)->surface().committed().size(), 0u);
  EXPECT_EQ(sim->client(0)->stats().rejected_messages, 0u);
  // Stage events: a batch goes available -> sent -> received -> desired -> queued -> published -> first frame.
  EventLog& ev = sim->client(0)->events();
  const StageEvent* rx = nullptr;
  for (const auto& e : ev.events())
    if (!e.is_query && e.stage == static_cast<std::uint8_t>(BatchStage::FirstFrame)) rx = &e;
  ASSERT_NE(rx, nullptr);
  const auto* recv = ev.find_batch(0, Epoch{rx->epoch}, BatchStage::Received);
  ASSERT_NE(recv, nullptr);
  EXPECT_LE(recv->t, rx->t);
}

TEST(SimBasic, SameSeedSameFigures) {
  std::vector<double> runs;
  for (int k = 0; k < 2; ++k) {
    auto sim = Simulation::create(two_clients(11));
    ASSERT_TRUE(sim.ok());
    double acc = 0.0;
    sim->on_frame([&](const FrameSample& f) { acc += f.t * static_cast<double>(f.published + 3 * f.pending); });
    ASSERT_TRUE(sim->run_until(2.0).ok());
    runs.push_back(acc + static_cast<double>(sim->client(0)->published_checksum() % 1000003));
  }
  EXPECT_EQ(runs[0], runs[1]);
}

TEST(SimBasic, ReconnectAndCrashResynchronise) {
  auto sim = Simulation::create(two_clients(5));
  ASSERT_TRUE(sim.ok());
  ASSERT_TRUE(sim->run_until(0.6).ok());
  sim->disconnect(0, 0.2);
  sim->crash(1, 0.3);
  ASSERT_TRUE(sim->run_until(1.5).ok());
  ASSERT_TRUE(sim->run_until_converged(10.0).ok()) << sim->check_converged().message();
  EXPECT_GE(sim->client(0)->stats().resyncs, 1u);
  EXPECT_EQ(sim->client(1)->stats().resyncs, 1u);
}

TEST(SimBasic, QueryReservesBudgetForTheTarget) {
  auto cfg = two_clients(2);
  auto sim = Simulation::create(cfg);
  ASSERT_TRUE(sim.ok());
  ASSERT_TRUE(sim->run_until(1.0).ok());
  const auto& objs = sim->scene().objects();
  ASSERT_FALSE(objs.empty());
  const SemanticObject* target = nullptr;
  for (const auto& o : objs)
    if (!o.label.empty() && o.members.size() > 50) target = &o;
  ASSERT_NE(target, nullptr);
  msg::Query q;
  q.kind = msg::QueryKind::Instance;
  q.instance = target->id;
  q.rho = 0.6f;
  const std::uint32_t qid = sim->query(0, q);
  sim->stop_scene();
  ASSERT_TRUE(sim->run_until(2.5).ok());
  ASSERT_TRUE(sim->run_until_converged(10.0).ok()) << sim->check_converged().message();
  std::size_t on_target = 0;
  for (std::uint32_t s = 0; s < sim->client(0)->slots().capacity(); ++s) {
    GaussianId id{0};
    if (sim->client(0)->slots().occupant(SlotIndex{s}, id) && sim->client(0)->slots().records()[s].object == target->id) ++on_target;
  }
  EXPECT_GE(on_target, std::min<std::size_t>(target->members.size(), 200));  // floor(0.6 * 400) = 240 reserved
  EventLog& ev = sim->client(0)->events();
  EXPECT_NE(ev.find_query(0, qid, QueryStage::Highlight), nullptr);
  EXPECT_NE(ev.find_query(0, qid, QueryStage::InitialResidency), nullptr);
  EXPECT_NE(ev.find_query(0, qid, QueryStage::Converged), nullptr);
}
