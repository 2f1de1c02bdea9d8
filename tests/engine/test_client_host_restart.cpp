// ClientState across a host restart (CPU only, no links): epochs are per host session,
// so a restarted host counts from its start again. Its Welcome carries a new session id;
// the client must then accept the new session's resync of an OLDER epoch number, reconcile
// to exactly what the new host sent (Gaussians and surface), and keep the epoch barrier.
// (Before the fix the resync was refused as "older than the last received epoch", the
// surface patches as stale, and the client kept the dead host's state for ever.)
#include <gtest/gtest.h>

#include "gauss/engine/client_state.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/synthetic_scene.h"
#include "host_world.h"

using namespace gauss;

namespace {

// A host's scene: `epochs` synthetic epochs, then one surface epoch with `chunks`.
using World = gauss::test::HostWorld;
using gauss::test::triangle_chunk;

// Connects `client` to `host` and delivers until nothing is pending.
void connect_and_settle(HostSession& host, ClientState& client, World& w, double t) {
  for (const auto& m : host.on_message(client.hello(), w.store, t)) ASSERT_TRUE(client.on_message(m, t).ok());
  auto out = host.tick(w.store, t);
  ASSERT_TRUE(out.ok()) << out.message();
  for (const auto& m : *out) {
    auto st = client.on_message(m, t);
    ASSERT_TRUE(st.ok()) << st.message();
  }
  for (std::uint64_t f = 0; f < 50; ++f) {
    ASSERT_TRUE(client.frame(ViewState{}, t, f).ok());
    ASSERT_TRUE(client.check().ok()) << client.check().message();
  }
  ASSERT_EQ(client.desired().pending_count(), 0u);
  for (const auto& m : client.take_outgoing()) (void)host.on_message(m, w.store, t);
}

}  // namespace

TEST(ClientState, FollowsARestartedHostWhoseEpochsStartOver) {
  ClientConfig cfg;
  cfg.capacity = 400;
  cfg.publisher.mode = PublishMode::Immediate;
  auto client = ClientState::create(0, cfg);
  ASSERT_TRUE(client.ok());

  World a(4, {triangle_chunk(1, 0.0f), triangle_chunk(2, 5.0f)});
  {
    HostSession host(1, /*session_id=*/9, a.params);
    connect_and_settle(host, *client, a, 0.0);
    EXPECT_EQ(client->desired().desired_checksum(), host.sent_checksum());
  }
  const auto epoch_a = client->desired().published_epoch();
  ASSERT_TRUE(epoch_a.has_value());
  ASSERT_EQ(client->surface().committed().size(), 2u);
  client->on_disconnect();

  // The host process restarts: a new session id, a scene whose epochs count from the start
  // again (ending below where the old one was), chunk 1 changed, chunk 2 gone, chunk 3 new.
  World b(1, {triangle_chunk(1, 1.0f), triangle_chunk(3, 9.0f)});
  ASSERT_LT(to_underlying(b.store.epoch()), to_underlying(*epoch_a));
  HostSession host(1, /*session_id=*/10, b.params);
  connect_and_settle(host, *client, b, 1.0);

  EXPECT_EQ(client->stats().resyncs, 2u);
  EXPECT_EQ(client->desired().desired_checksum(), host.sent_checksum()) << "the new host's set, exactly";
  EXPECT_EQ(client->published_checksum(), client->desired().desired_checksum()) << "no stale slots";
  ASSERT_TRUE(client->desired().published_epoch().has_value());
  EXPECT_EQ(to_underlying(*client->desired().published_epoch()), to_underlying(b.store.epoch()));
  const auto& surf = client->surface().committed();
  ASSERT_EQ(surf.size(), 2u);
  ASSERT_EQ(surf.count(1), 1u);
  ASSERT_EQ(surf.count(3), 1u);
  EXPECT_EQ(surf.at(1).mesh.positions[0].x, 1.0f);
  EXPECT_EQ(client->surface().pending_count(), 0u);
  ASSERT_TRUE(client->surface().committed_epoch().has_value());
  EXPECT_LE(to_underlying(*client->surface().committed_epoch()), to_underlying(*client->desired().published_epoch()));
  EXPECT_TRUE(client->check().ok()) << client->check().message();

  // The same host again (a plain reconnect, same session): nothing restarts, nothing changes.
  const std::uint64_t before = client->published_checksum();
  client->on_disconnect();
  HostSession again(2, /*session_id=*/10, b.params);
  connect_and_settle(again, *client, b, 2.0);
  EXPECT_EQ(client->published_checksum(), before);
  EXPECT_EQ(client->surface().committed().size(), 2u);
  EXPECT_TRUE(client->check().ok()) << client->check().message();
}
