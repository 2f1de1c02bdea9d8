// ClientState's query stage events (CPU only, no links): the residency a query starts
// from is counted when its reply arrives, so "first additional content" fires even when
// the reply and the batch it causes reach the client before the same frame (the usual
// case over a fast link). Before the fix the first frame after both counted the new
// content as the starting residency and the event never came.
#include <optional>

#include <gtest/gtest.h>

#include "gauss/engine/client_state.h"
#include "gauss/engine/host_session.h"
#include "host_world.h"

using namespace gauss;

namespace {

void deliver(ClientState& client, const std::vector<wire::Message>& messages, double t) {
  for (const auto& m : messages) {
    const Status st = client.on_message(m, t);
    ASSERT_TRUE(st.ok()) << st.message();
  }
}

// A client of 300 slots publishing immediately, welcomed by `host`, with the host's first
// batch delivered and not yet published.
class ClientStateEvents : public ::testing::Test {
 protected:
  void SetUp() override {
    ClientConfig cfg;
    cfg.capacity = 300;
    cfg.publisher.mode = PublishMode::Immediate;
    auto c = ClientState::create(0, cfg);
    ASSERT_TRUE(c.ok());
    client.emplace(std::move(*c));
    ASSERT_NO_FATAL_FAILURE(deliver(*client, host.on_message(client->hello(), w.store, 0.0), 0.0));
    auto first = host.tick(w.store, 0.0);
    ASSERT_TRUE(first.ok()) << first.message();
    ASSERT_NO_FATAL_FAILURE(deliver(*client, *first, 0.0));
  }

  gauss::test::HostWorld w{2};
  HostSession host{1, 9, w.params};
  std::optional<ClientState> client;
};

}  // namespace

TEST_F(ClientStateEvents, FirstAdditionalFiresWhenReplyAndBatchArriveTogether) {
  std::uint64_t frame = 0;
  for (; frame < 5; ++frame) ASSERT_TRUE(client->frame(ViewState{}, 0.0, frame).ok());
  ASSERT_EQ(client->desired().pending_count(), 0u);
  for (const auto& m : client->take_outgoing()) (void)host.on_message(m, w.store, 0.0);

  // The largest object, which the budget cannot hold whole without the query.
  const SemanticObject* target = nullptr;
  for (const SemanticObject& o : w.store.objects())
    if (!target || o.members.size() > target->members.size()) target = &o;
  ASSERT_NE(target, nullptr);
  ASSERT_GT(target->members.size(), 50u);
  msg::Query q;
  q.kind = msg::QueryKind::Instance;
  q.instance = target->id;
  q.rho = 0.9f;
  const std::uint32_t qid = client->send_query(q);
  std::vector<wire::Message> to_client;
  for (const auto& m : client->take_outgoing())
    for (auto& r : host.on_message(m, w.store, 1.0)) to_client.push_back(std::move(r));
  auto batch = host.tick(w.store, 1.0);
  ASSERT_TRUE(batch.ok()) << batch.message();
  for (auto& m : *batch) to_client.push_back(std::move(m));
  ASSERT_GE(to_client.size(), 2u) << "the reply and a batch";
  ASSERT_NO_FATAL_FAILURE(deliver(*client, to_client, 1.0));  // both before the next frame
  for (std::uint64_t end = frame + 5; frame < end; ++frame) {
    ASSERT_TRUE(client->frame(ViewState{}, 1.0, frame).ok());
    client->frame_rendered(1.0, frame);
  }

  const EventLog& ev = client->events();
  const StageEvent* initial = ev.find_query(0, qid, QueryStage::InitialResidency);
  const StageEvent* more = ev.find_query(0, qid, QueryStage::FirstAdditional);
  const StageEvent* converged = ev.find_query(0, qid, QueryStage::Converged);
  ASSERT_NE(initial, nullptr);
  ASSERT_NE(more, nullptr) << "the batch that arrived with the reply added target content";
  ASSERT_NE(converged, nullptr);
  EXPECT_GT(more->count, initial->count);
  EXPECT_EQ(more->frame, initial->frame) << "both in the first frame after the reply";
  EXPECT_LE(more->frame, converged->frame);
}

// A client that publishes ahead of its display (ClientRuntime's publication thread) says
// which publication step a rendered frame shows: a batch published by a later step is not
// on screen yet, so its first-frame event waits for the frame that shows that step.
TEST_F(ClientStateEvents, FirstFrameWaitsForTheFrameShowingThePublishingStep) {
  auto step = client->frame(ViewState{}, 0.5, 0);
  ASSERT_TRUE(step.ok()) << step.message();
  ASSERT_EQ(step->step, 1u);
  ASSERT_EQ(client->desired().pending_count(), 0u) << "immediate mode published the first batch whole";
  const Epoch epoch = *step->published_epoch;
  const EventLog& ev = client->events();
  ASSERT_NE(ev.find_batch(0, epoch, BatchStage::Published), nullptr);

  client->frame_rendered(0.6, 0, 0);  // a frame showing no step yet
  EXPECT_EQ(ev.find_batch(0, epoch, BatchStage::FirstFrame), nullptr);
  auto next = client->frame(ViewState{}, 0.7, 1);
  ASSERT_TRUE(next.ok());
  EXPECT_EQ(next->step, 2u);
  client->frame_rendered(0.8, 1, 1);  // the frame that shows step 1
  const StageEvent* shown = ev.find_batch(0, epoch, BatchStage::FirstFrame);
  ASSERT_NE(shown, nullptr);
  EXPECT_DOUBLE_EQ(shown->t, 0.8);
  EXPECT_EQ(shown->frame, 1u);
}
