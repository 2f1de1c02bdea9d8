// End to end over loopback ENet: a host streams an evolving synthetic scene to two
// clients with different budgets. At every display frame each client holds <= M
// and passes every invariant (ClientState::check: slot bijection, desired-state
// consistency, epoch barrier); at the end each client's published set equals its
// desired set equals what the host sent, by checksum of ids and records.
#include "stream_harness.h"

namespace gauss {
namespace {

TEST(StreamLoopback, TwoClientsWithDifferentBudgetsConvergeExactly) {
  test::StreamHarness h({});
  ASSERT_TRUE(h.ready());
  auto small = h.connect("small", 3000, h.port(), 0);
  auto large = h.connect("large", 9000, h.port(), 5);
  ASSERT_TRUE(small && large);
  const bool ok = h.run_until_converged({small.get(), large.get()}, std::chrono::seconds(25));
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  EXPECT_TRUE(ok) << h.describe(*small) << "\n" << h.describe(*large);
  EXPECT_LE(small->max_published, 3000u);
  EXPECT_LE(large->max_published, 9000u);
  // The budgets bind: the scene is larger than either, so each holds exactly M.
  EXPECT_EQ(small->sink->with_state([](ClientState& s) { return s.slots().size(); }), 3000u);
  EXPECT_EQ(large->sink->with_state([](ClientState& s) { return s.slots().size(); }), 9000u);
  EXPECT_EQ(small->sink->rejected(), 0u);
  EXPECT_EQ(large->sink->rejected(), 0u);
  const auto hc = h.host().net().counters();
  EXPECT_EQ(hc.malformed + hc.wrong_direction, 0u);
  EXPECT_EQ(h.host().stats().tick_errors, 0u) << h.host().stats().last_error;
}

TEST(StreamLoopback, AccessTokenRefusesAClientWithoutIt) {
  test::StreamHarness::Options o;
  o.access_token = "let-me-in";
  test::StreamHarness h(o);
  ASSERT_TRUE(h.ready());
  // A client process with the wrong token: refused, never gets a session or data.
  auto c = std::make_unique<test::StreamClient>();
  gauss::ClientConfig cc;
  cc.capacity = 1000;
  auto st = ClientState::create(0, cc);
  ASSERT_TRUE(st.ok());
  c->state = std::make_unique<ClientState>(std::move(st).value());
  c->sink = std::make_unique<net::ClientStateSink>(*c->state, [] { return 0.0; });
  net::NetClientConfig nc;
  nc.server = {"127.0.0.1", h.port()};
  nc.slot_capacity = 1000;
  nc.log = [](const std::string&) {};
  auto n = net::NetClient::start(nc, *c->sink);
  ASSERT_TRUE(n.ok());
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while ((*n)->status() != net::ClientStatus::Refused && std::chrono::steady_clock::now() < until) h.step({});
  EXPECT_EQ((*n)->status(), net::ClientStatus::Refused);
  EXPECT_TRUE(c->sink->refused());
  EXPECT_EQ(h.host().clients().size(), 0u);
  EXPECT_EQ(h.host().net().counters().refused_token, 1u);
  EXPECT_EQ(c->state->slots().size(), 0u);

  // The right token streams.
  auto good = h.connect("good", 2000, h.port());
  ASSERT_TRUE(good);
  EXPECT_TRUE(h.run_until_converged({good.get()}, std::chrono::seconds(25))) << h.describe(*good);
}

}  // namespace
}  // namespace gauss
