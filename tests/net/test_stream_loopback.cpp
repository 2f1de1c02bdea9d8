// End to end over loopback ENet: a host streams an evolving synthetic scene to two
// clients with different budgets. At every display frame each client holds <= M
// and passes every invariant (ClientState::check: slot bijection, desired-state
// consistency, epoch barrier); at the end each client's published set equals its
// desired set equals what the host sent, by checksum of ids and records.
#include <algorithm>
#include <cstdio>

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
  EXPECT_TRUE(ok) << h.describe(*small) << "\n" << h.describe(*large) << h.log_tail();
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
  // For the record (not a pass/fail figure): what the stream cost on the wire.
  std::printf("loopback stream: %llu messages, %llu bytes sent by the host; frames small %llu large %llu\n",
              static_cast<unsigned long long>(hc.messages_sent), static_cast<unsigned long long>(hc.bytes_sent),
              static_cast<unsigned long long>(small->frames), static_cast<unsigned long long>(large->frames));
}

TEST(StreamLoopback, WithLodTheHierarchyIsUpdatedInTheBackgroundAndClientsConvergeExactly) {
  // SessionHost's LoD: every epoch's hierarchy update runs on a worker thread while the pump
  // goes on; the sessions wait for it and then send the epoch (its received epoch is the
  // scene's last). Budgets below the scene: coarse records must arrive, within M.
  test::StreamHarness::Options o;
  o.lod = true;
  test::StreamHarness h(o);
  ASSERT_TRUE(h.ready());
  auto small = h.connect("small", 2500, h.port(), 0);
  auto large = h.connect("large", 6000, h.port(), 5);
  ASSERT_TRUE(small && large);
  const bool ok = h.run_until_converged({small.get(), large.get()}, std::chrono::seconds(25));
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  EXPECT_TRUE(ok) << h.describe(*small) << "\n" << h.describe(*large) << h.log_tail();
  for (test::StreamClient* c : {small.get(), large.get()}) {
    EXPECT_LE(c->max_published, c->capacity) << c->name;
    EXPECT_EQ(c->sink->rejected(), 0u) << c->name;
    const HostSession* hs = h.host().session(c->sink->client_id());
    ASSERT_NE(hs, nullptr);
    EXPECT_GT(std::count_if(hs->sent_ids().begin(), hs->sent_ids().end(), is_lod_interior_id), 0) << c->name;
  }
  EXPECT_FALSE(h.host().lod_busy());
  // The first epoch's build is said once, with its figures (gauss-host prints it).
  const std::string logs = h.log_tail();
  EXPECT_NE(logs.find("host: LoD: hierarchy for epoch 1 built in "), std::string::npos) << logs;
  EXPECT_NE(logs.find(" leaves, "), std::string::npos) << logs;
  EXPECT_EQ(logs.find("built in", logs.find("built in") + 1), std::string::npos) << "said once" << logs;
  EXPECT_EQ(h.host().stats().lod_failures, 0u) << h.host().stats().last_error;
  EXPECT_EQ(h.host().stats().tick_errors, 0u) << h.host().stats().last_error;
}

// Malformed and out-of-place messages injected into a live, streaming connection:
// each is rejected and counted by the transport, never reaches the host session
// (its state and counters stay untouched), and the stream still converges exactly.
TEST(StreamLoopback, MalformedMessagesMidStreamAreRejectedAndHarmless) {
  test::StreamHarness h({});
  ASSERT_TRUE(h.ready());
  auto c = h.connect("target", 4000, h.port(), 3);
  ASSERT_TRUE(c);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < until &&
         c->sink->with_state([](ClientState& s) { return s.slots().size(); }) < 1000)
    h.step({c.get()});
  HostSession* session = h.host().session(c->sink->client_id());
  ASSERT_NE(session, nullptr);
  const HostSessionStats before = session->stats();

  auto ack = wire::encode(msg::Ack{1, Epoch{1}, Epoch{0}}).value();
  auto scene_info = wire::encode(msg::SceneInfo{}).value();  // a host-only message
  std::vector<std::vector<std::uint8_t>> bad = {
      {0x00},
      {0x0B, 0x00, 0x00, 0x00, 0x18, 0x00, 0x00, 0x00},      // Ack header, body missing
      std::vector<std::uint8_t>(ack.begin(), ack.end() - 1),  // truncated
      {0xFF, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00},      // unknown type
      scene_info,
  };
  ack[2] = 7;  // reserved bits set
  bad.push_back(ack);
  for (int round = 0; round < 5; ++round)
    for (const auto& b : bad) ASSERT_TRUE(c->net->send_raw(b, static_cast<std::uint8_t>(round % 2)).ok());
  const std::uint64_t expected = 5 * bad.size();
  const auto seen = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < seen) {
    const auto hc = h.host().net().counters();
    if (hc.malformed + hc.wrong_direction >= expected) break;
    h.step({c.get()});
  }
  const auto hc = h.host().net().counters();
  EXPECT_EQ(hc.malformed, 5u * (bad.size() - 1));
  EXPECT_EQ(hc.wrong_direction, 5u);
  EXPECT_EQ(hc.kicked, 0u);
  EXPECT_FALSE(hc.last_rejection.empty());
  // Nothing reached the policy: its rejection counters did not move.
  session = h.host().session(c->sink->client_id());
  ASSERT_NE(session, nullptr) << "the connection was dropped";
  EXPECT_EQ(session->stats().rejected_messages, before.rejected_messages);
  EXPECT_EQ(c->net->status(), net::ClientStatus::Connected);
  EXPECT_TRUE(h.run_until_converged({c.get()}, std::chrono::seconds(25))) << h.describe(*c) << h.log_tail();
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
  EXPECT_EQ(h.host().net().counters().refused_token, 0u) << "the client gave up at the challenge";
  EXPECT_EQ(c->state->slots().size(), 0u);

  // The right token streams.
  auto good = h.connect("good", 2000, h.port());
  ASSERT_TRUE(good);
  EXPECT_TRUE(h.run_until_converged({good.get()}, std::chrono::seconds(25))) << h.describe(*good) << h.log_tail();
}

// A sealed stream carries the same content: two hosts on the same scene, one plain and
// one sealed, bring the same client (budget, camera) to the same published set.
TEST(StreamLoopback, ASealedStreamEndsInTheSameStateAsAPlainOne) {
  std::uint64_t checksum[2] = {0, 0};
  std::uint64_t bytes[2] = {0, 0};
  for (int sealed = 0; sealed < 2; ++sealed) {
    test::StreamHarness::Options o;
    o.access_token = "private-scene";
    o.encrypt_stream = sealed == 1;
    test::StreamHarness h(o);
    ASSERT_TRUE(h.ready());
    auto c = h.connect("viewer", 4000, h.port(), 3);
    ASSERT_TRUE(c);
    const bool ok = h.run_until_converged({c.get()}, std::chrono::seconds(25));
    ASSERT_FALSE(::testing::Test::HasFatalFailure());
    ASSERT_TRUE(ok) << (sealed ? "sealed: " : "plain: ") << h.describe(*c) << h.log_tail();
    EXPECT_EQ(c->sink->rejected(), 0u);
    const auto hc = h.host().net().counters();
    EXPECT_EQ(hc.malformed + hc.wrong_direction, 0u) << hc.last_rejection;
    checksum[sealed] = c->sink->with_state([](ClientState& s) { return s.published_checksum(); });
    bytes[sealed] = hc.bytes_sent;
  }
  EXPECT_EQ(checksum[0], checksum[1]) << "the sealed stream published another set";
  std::printf("plain stream %llu bytes, sealed %llu bytes\n", static_cast<unsigned long long>(bytes[0]),
              static_cast<unsigned long long>(bytes[1]));
}

}  // namespace
}  // namespace gauss
