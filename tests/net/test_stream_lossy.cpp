// The same end-to-end stream through a seeded lossy UDP relay (10 % loss each way,
// 50 ms delay with 20 ms jitter, which reorders, and 5 % duplication): the same exact
// final state. Plus the faults: a client killed and restarted resynchronises, and a
// client that keeps its state through a link outage reconnects and reconciles.
#include "stream_harness.h"

namespace gauss {
namespace {

net::RelayPolicy lossy(std::uint64_t seed) {
  net::RelayPolicy p;
  p.seed = seed;
  p.loss = 0.10;
  p.duplicate = 0.05;
  p.delay = std::chrono::milliseconds(50);
  p.jitter = std::chrono::milliseconds(20);
  return p;
}

std::unique_ptr<net::UdpRelay> relay_to(test::StreamHarness& h, const net::RelayPolicy& p) {
  auto r = net::UdpRelay::start({"127.0.0.1", 0}, {"127.0.0.1", h.port()}, p);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
  return r.ok() ? std::move(r).value() : nullptr;
}

TEST(StreamLossy, LossDelayReorderAndDuplicationGiveTheSameExactState) {
  test::StreamHarness h({});
  ASSERT_TRUE(h.ready());
  auto relay = relay_to(h, lossy(1234));
  ASSERT_TRUE(relay);
  auto a = h.connect("a", 2500, relay->port(), 0);
  auto b = h.connect("b", 6000, relay->port(), 9);
  ASSERT_TRUE(a && b);
  const bool ok = h.run_until_converged({a.get(), b.get()}, std::chrono::seconds(28));
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  EXPECT_TRUE(ok) << h.describe(*a) << "\n" << h.describe(*b) << h.log_tail();
  const auto rc = relay->counters();
  // The link really was hostile (counts from the seeded policy, not timing).
  EXPECT_GT(rc.dropped, 0u);
  EXPECT_GT(rc.duplicated, 0u);
  EXPECT_GT(rc.reordered, 0u);
  EXPECT_LE(a->max_published, 2500u);
  EXPECT_LE(b->max_published, 6000u);
}

TEST(StreamLossy, AKilledClientRestartsAndResynchronises) {
  test::StreamHarness h({});
  ASSERT_TRUE(h.ready());
  auto relay = relay_to(h, lossy(99));
  ASSERT_TRUE(relay);
  auto steady = h.connect("steady", 3000, relay->port(), 0);
  auto victim = h.connect("victim", 4000, relay->port(), 4);
  ASSERT_TRUE(steady && victim);
  // Run until the victim holds something, then kill it mid-stream: no goodbye.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < until &&
         victim->sink->with_state([](ClientState& s) { return s.slots().size(); }) < 500)
    h.step({steady.get(), victim.get()});
  ASSERT_GE(victim->sink->with_state([](ClientState& s) { return s.slots().size(); }), 500u);
  const std::uint32_t old_id = victim->sink->client_id();
  victim->net->abandon();
  victim.reset();

  // A new process: empty state, same budget. The host was never restarted.
  auto reborn = h.connect("victim", 4000, relay->port(), 4);
  ASSERT_TRUE(reborn);
  const bool ok = h.run_until_converged({steady.get(), reborn.get()}, std::chrono::seconds(25));
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  EXPECT_TRUE(ok) << h.describe(*steady) << "\n" << h.describe(*reborn) << h.log_tail();
  EXPECT_NE(reborn->sink->client_id(), old_id);
  // The dead connection is noticed by peer timeout and its session freed.
  const auto gone = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (h.host().session(old_id) != nullptr && std::chrono::steady_clock::now() < gone)
    h.step({steady.get(), reborn.get()});
  EXPECT_EQ(h.host().session(old_id), nullptr);
  EXPECT_GE(h.host().stats().sessions_closed, 1u);
}

TEST(StreamLossy, ALinkOutageReconnectsAndReconcilesWithoutHostRestart) {
  test::StreamHarness::Options o;
  o.epochs = 10;
  o.epoch_period_s = 0.3;
  test::StreamHarness h(o);
  ASSERT_TRUE(h.ready());
  net::RelayPolicy clean;
  clean.seed = 5;
  auto relay = relay_to(h, clean);
  ASSERT_TRUE(relay);
  auto c = h.connect("roamer", 3000, relay->port(), 2);
  ASSERT_TRUE(c);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < until &&
         c->sink->with_state([](ClientState& s) { return s.slots().size(); }) < 3000)
    h.step({c.get()});
  const std::uint32_t first_id = c->sink->client_id();
  // Near-total loss until both ends time out (peer timeout max 2 s in the harness).
  net::RelayPolicy dead = clean;
  dead.loss = 0.9999;
  relay->set_policy(dead);
  const auto outage = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while (std::chrono::steady_clock::now() < outage && c->net->status() == net::ClientStatus::Connected)
    h.step({c.get()});
  ASSERT_NE(c->net->status(), net::ClientStatus::Connected) << "the outage was not noticed";
  relay->set_policy(clean);
  // The client kept its state; the new Welcome's resync reconciles it.
  const bool ok = h.run_until_converged({c.get()}, std::chrono::seconds(25));
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  EXPECT_TRUE(ok) << h.describe(*c) << h.log_tail();
  EXPECT_NE(c->sink->client_id(), first_id);
  EXPECT_GE(c->net->counters().welcomes, 2u);
  EXPECT_GE(c->sink->with_state([](ClientState& s) { return s.stats().resyncs; }), 2u);
}

}  // namespace
}  // namespace gauss
