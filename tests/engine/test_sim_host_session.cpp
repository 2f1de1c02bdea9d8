// HostSession and ClientState on their own (no links): the handshake checks, bad input
// rejected with counters and state untouched, the query rate limit, resync.
#include <gtest/gtest.h>

#include "gauss/engine/client_state.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/synthetic_scene.h"
#include "host_world.h"

using namespace gauss;

namespace {

using World = gauss::test::HostWorld;
using gauss::test::triangle_chunk;

msg::Hello hello(std::uint32_t cap, std::string token = {}) {
  msg::Hello h;
  h.slot_capacity = cap;
  h.access_token = std::move(token);
  return h;
}

}  // namespace

TEST(HostSession, RefusesBadHellos) {
  World w;
  HostSessionConfig cfg;
  cfg.access_token = "secret";
  struct Case {
    msg::Hello h;
    msg::RefuseReason why;
  };
  msg::Hello old = hello(100, "secret");
  old.protocol_version = msg::kProtocolVersion + 1;
  for (const Case& c : {Case{hello(100), msg::RefuseReason::BadToken}, Case{hello(100, "guess"), msg::RefuseReason::BadToken},
                        Case{hello(0, "secret"), msg::RefuseReason::BadCapacity},
                        Case{hello(1000000000u, "secret"), msg::RefuseReason::BadCapacity},
                        Case{old, msg::RefuseReason::VersionMismatch}}) {
    HostSession s(1, 9, w.params, cfg);
    auto out = s.on_message(c.h, w.store, 0.0);
    ASSERT_EQ(out.size(), 1u);
    const auto* refuse = std::get_if<msg::Refuse>(&out[0]);
    ASSERT_NE(refuse, nullptr);
    EXPECT_EQ(refuse->reason, c.why);
    EXPECT_TRUE(s.closed());
    EXPECT_FALSE(s.accepted());
    auto t = s.tick(w.store, 0.1);
    ASSERT_TRUE(t.ok());
    EXPECT_TRUE(t->empty());  // a refused client gets nothing
  }
  HostSession ok(1, 9, w.params, cfg);
  auto out = ok.on_message(hello(300, "secret"), w.store, 0.0);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_TRUE(std::holds_alternative<msg::Welcome>(out[0]));
  EXPECT_EQ(std::get<msg::Welcome>(out[0]).slot_capacity, 300u);
}

TEST(HostSession, BadMessagesAreCountedAndChangeNothing) {
  World w;
  HostSession s(1, 9, w.params);
  EXPECT_TRUE(s.on_message(msg::HeadPose{}, w.store, 0.0).empty());
  EXPECT_EQ(s.stats().rejected_before_hello, 1u);
  ASSERT_EQ(s.on_message(hello(200), w.store, 0.0).size(), 1u);
  EXPECT_TRUE(s.on_message(hello(200), w.store, 0.0).empty());
  EXPECT_EQ(s.stats().rejected_duplicate_hello, 1u);
  EXPECT_TRUE(s.on_message(msg::Welcome{}, w.store, 0.0).empty());  // host-only type from a client
  EXPECT_EQ(s.stats().rejected_direction, 1u);
  msg::HeadPose p;
  p.sequence = 5;
  EXPECT_TRUE(s.on_message(p, w.store, 0.0).empty());
  p.sequence = 4;
  EXPECT_TRUE(s.on_message(p, w.store, 0.0).empty());
  EXPECT_EQ(s.stats().stale_poses, 1u);
  msg::Ack bogus;
  bogus.last_batch_id = 77;  // never sent
  EXPECT_TRUE(s.on_message(bogus, w.store, 0.0).empty());
  EXPECT_FALSE(s.last_ack().has_value());
  EXPECT_GE(s.stats().rejected_messages, 5u);
  EXPECT_TRUE(s.accepted());
  EXPECT_FALSE(s.closed());
  // First tick: scene info, a resync snapshot within the budget.
  auto t = s.tick(w.store, 0.1);
  ASSERT_TRUE(t.ok()) << t.message();
  ASSERT_GE(t->size(), 2u);
  EXPECT_TRUE(std::holds_alternative<msg::SceneInfo>((*t)[0]));
  const auto& b = std::get<msg::EditBatchMsg>((*t)[1]);
  EXPECT_EQ(b.flags & msg::kBatchResync, msg::kBatchResync);
  EXPECT_LE(b.edit_count, 200u);
  EXPECT_GT(b.edit_count, 100u);
}

TEST(HostSession, QueryFloodIsRateLimited) {
  World w;
  HostSessionConfig cfg;
  cfg.query_burst = 3;
  cfg.queries_per_s = 2.0;
  HostSession s(1, 9, w.params, cfg);
  ASSERT_EQ(s.on_message(hello(200), w.store, 0.0).size(), 1u);
  ASSERT_FALSE(w.store.objects().empty());
  msg::Query q;
  q.kind = msg::QueryKind::Instance;
  q.instance = w.store.objects().front().id;
  q.rho = 0.5f;
  int resolved = 0, rejected = 0;
  for (int i = 0; i < 50; ++i) {
    auto out = s.on_message(q, w.store, 1.0);
    ASSERT_EQ(out.size(), 1u);
    const auto& r = std::get<msg::QueryReply>(out[0]);
    if (r.status == msg::QueryStatus::Rejected) {
      ++rejected;
      EXPECT_NE(r.reason.find("rate limit"), std::string::npos);
    } else {
      ++resolved;
    }
  }
  EXPECT_EQ(resolved, 3);
  EXPECT_EQ(rejected, 47);
  EXPECT_EQ(s.stats().rejected_queries, 47u);
  // Half a second later one more token has arrived.
  auto later = s.on_message(q, w.store, 1.5);
  EXPECT_EQ(std::get<msg::QueryReply>(later[0]).status, msg::QueryStatus::Resolved);
  // Unknown instance: a valid query that matches nothing; selection unchanged.
  q.instance = ObjectId{987654};
  auto none = s.on_message(q, w.store, 10.0);
  EXPECT_EQ(std::get<msg::QueryReply>(none[0]).status, msg::QueryStatus::NoMatch);
}

TEST(ClientState, RejectsCapacityAndBadHostMessages) {
  ClientConfig bad;
  bad.capacity = 0;
  EXPECT_FALSE(ClientState::create(0, bad).ok());
  bad.capacity = 1000000000u;
  EXPECT_FALSE(ClientState::create(0, bad).ok());
  ClientConfig cfg;
  cfg.capacity = 100;
  auto c = ClientState::create(0, cfg);
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(c->on_message(msg::SceneInfo{}, 0.0).ok());  // before the Welcome
  EXPECT_FALSE(c->on_message(msg::Hello{}, 0.0).ok());      // client-only type
  EXPECT_FALSE(c->on_message(msg::Welcome{msg::kProtocolVersion, 1, 1, 500}, 0.0).ok());  // grants more than asked
  ASSERT_TRUE(c->on_message(msg::Welcome{msg::kProtocolVersion, 1, 1, 100}, 0.0).ok());
  msg::EditBatchMsg b;
  b.epoch = Epoch{1};
  b.batch_id = 1;
  b.payload = {1, 2, 3};
  EXPECT_FALSE(c->on_message(b, 0.0).ok());  // no SceneInfo yet: no codec
  msg::SceneInfo info;
  ASSERT_TRUE(c->on_message(info, 0.0).ok());
  auto r = c->on_message(b, 0.0);  // garbage payload
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("edit batch 1"), std::string::npos);
  EXPECT_EQ(c->desired().desired_count(), 0u);
  EXPECT_GE(c->stats().rejected_messages, 5u);
  EXPECT_TRUE(c->check().ok());
}

TEST(ClientState, FollowsAHostSessionToAnExactCopy) {
  World w;
  HostSession host(1, 9, w.params);
  ClientConfig cfg;
  cfg.capacity = 250;
  cfg.publisher.mode = PublishMode::Progressive;
  cfg.publisher.allowance_min = cfg.publisher.allowance_initial = cfg.publisher.allowance_max = 40;
  auto client = ClientState::create(0, cfg);
  ASSERT_TRUE(client.ok());
  for (const auto& m : host.on_message(client->hello(), w.store, 0.0)) ASSERT_TRUE(client->on_message(m, 0.0).ok());
  auto out = host.tick(w.store, 0.0);
  ASSERT_TRUE(out.ok());
  for (const auto& m : *out) ASSERT_TRUE(client->on_message(m, 0.0).ok());
  std::uint64_t frame = 0;
  std::size_t max_writes = 0;
  while (client->desired().pending_count() > 0) {
    auto f = client->frame(ViewState{}, 0.01 * static_cast<double>(frame), frame);
    ASSERT_TRUE(f.ok()) << f.message();
    max_writes = std::max<std::size_t>(max_writes, f->publish.slot_writes());
    for (const auto& r : f->ranges) ASSERT_LE(r.first + r.count, 250u);
    client->frame_rendered(0.0, frame);
    ASSERT_TRUE(client->check().ok()) << client->check().message();
    ASSERT_LT(++frame, 100u);
  }
  EXPECT_LE(max_writes, 40u);
  EXPECT_EQ(client->published_checksum(), client->desired().desired_checksum());
  EXPECT_EQ(client->desired().desired_checksum(), host.sent_checksum());
  // Acks flow back and the host takes them.
  for (const auto& m : client->take_outgoing()) (void)host.on_message(m, w.store, 1.0);
  ASSERT_TRUE(host.last_ack().has_value());
  EXPECT_EQ(host.last_ack()->last_batch_id, host.last_batch_id());
}

namespace {

// Delivers everything the host sends, then displays frames until nothing is pending.
void deliver_and_settle(HostSession& host, ClientState& client, World& w, double t) {
  auto out = host.tick(w.store, t);
  ASSERT_TRUE(out.ok()) << out.message();
  for (const auto& m : *out) ASSERT_TRUE(client.on_message(m, t).ok());
  for (std::uint64_t f = 0; f < 50; ++f) {
    ASSERT_TRUE(client.frame(ViewState{}, t, f).ok());
    ASSERT_TRUE(client.check().ok()) << client.check().message();
  }
  for (const auto& m : client.take_outgoing()) (void)host.on_message(m, w.store, t);
}

}  // namespace

// A chunk the scene dropped while the client was away must not stay on the client's
// screen after the reconnect: the resync resends the whole surface, and whatever the
// client holds that the resync did not resend is stale. (It stayed committed for ever:
// the resync only ever sent chunks the scene still had.)
TEST(ClientState, ResyncDropsSurfaceChunksTheSceneLostMeanwhile) {
  World w;
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.set_surface_chunk(triangle_chunk(1, 0.0f)).ok());
  ASSERT_TRUE(w.store.set_surface_chunk(triangle_chunk(2, 5.0f)).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  ClientConfig cfg;
  cfg.capacity = 500;
  cfg.publisher.mode = PublishMode::Immediate;
  auto client = ClientState::create(0, cfg);
  ASSERT_TRUE(client.ok());
  {
    HostSession host(1, 9, w.params);
    for (const auto& m : host.on_message(client->hello(), w.store, 0.0)) ASSERT_TRUE(client->on_message(m, 0.0).ok());
    deliver_and_settle(host, *client, w, 0.0);
  }
  ASSERT_EQ(client->surface().committed().size(), 2u);
  client->on_disconnect();

  // Meanwhile chunk 2 disappears and chunk 1 changes.
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.remove_surface_chunk(2).ok());
  ASSERT_TRUE(w.store.set_surface_chunk(triangle_chunk(1, 1.0f)).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());

  HostSession host(2, 9, w.params);  // a reconnect is a new session
  for (const auto& m : host.on_message(client->hello(), w.store, 1.0)) ASSERT_TRUE(client->on_message(m, 1.0).ok());
  deliver_and_settle(host, *client, w, 1.0);
  EXPECT_EQ(client->stats().resyncs, 2u);  // every Welcome is followed by a resync
  EXPECT_EQ(client->surface().stats().dropped_on_resync, 1u);
  ASSERT_EQ(client->surface().committed().size(), 1u);
  ASSERT_EQ(client->surface().committed().count(1), 1u);
  EXPECT_EQ(client->surface().committed().at(1).mesh.positions[0].x, 1.0f);
  EXPECT_EQ(client->surface().pending_count(), 0u);
  EXPECT_TRUE(client->check().ok()) << client->check().message();

  // A second reconnect with nothing changed keeps the surface as it is.
  client->on_disconnect();
  HostSession again(3, 9, w.params);
  for (const auto& m : again.on_message(client->hello(), w.store, 2.0)) ASSERT_TRUE(client->on_message(m, 2.0).ok());
  deliver_and_settle(again, *client, w, 2.0);
  EXPECT_EQ(client->surface().committed().size(), 1u);
  EXPECT_EQ(client->surface().committed().count(1), 1u);
}

// The view a host announces reaches the client with the codec: the config's when set, else a
// room standing inside the scene's bounds (the synthetic scene's, and today's clients' view).
TEST(ClientState, TakesTheViewTheHostAnnounces) {
  World w;
  auto view_after_welcome = [&](const HostSessionConfig& hc) {
    HostSession host(1, 9, w.params, hc);
    ClientConfig cfg;
    cfg.capacity = 100;
    auto client = ClientState::create(0, cfg);
    EXPECT_TRUE(client.ok());
    EXPECT_FALSE(client->view().has_value());
    for (const auto& m : host.on_message(client->hello(), w.store, 0.0)) EXPECT_TRUE(client->on_message(m, 0.0).ok());
    auto out = host.tick(w.store, 0.0);
    EXPECT_TRUE(out.ok());
    for (const auto& m : *out) EXPECT_TRUE(client->on_message(m, 0.0).ok());
    return client->view();
  };
  const auto room = view_after_welcome({});
  ASSERT_TRUE(room.has_value());
  EXPECT_EQ(room->flags, msg::kViewInside);
  EXPECT_EQ(room->up, glm::vec3(0.0f, 1.0f, 0.0f));
  EXPECT_EQ(room->subject_min, w.store.bounds().min);
  EXPECT_EQ(room->subject_max, w.store.bounds().max);

  HostSessionConfig hc;
  msg::SceneView capture;
  capture.up = {0.0f, -1.0f, 0.0f};
  capture.subject_min = {-1.0f, -2.0f, 3.0f};
  capture.subject_max = {1.0f, 0.5f, 4.0f};
  capture.flags = msg::kViewSeenFrom;
  capture.seen_from = {0.0f, 0.0f, 0.0f};
  hc.view = capture;
  const auto told = view_after_welcome(hc);
  ASSERT_TRUE(told.has_value());
  EXPECT_EQ(*told, capture);
}
