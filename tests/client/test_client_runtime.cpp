// ClientRuntime over the in-process link: an engine HostSession (the host's side of one
// connection) feeds the runtime's deliver(), the runtime's take_outgoing() goes back.
// After convergence the runtime's published set equals what the host sent (checksum),
// and its frame equals a blocking renderer's image of that set loaded in slot order
// with the committed surface: GPU publication (dirty ranges, clears, chunks) lost nothing.
// The same with publication on its own thread: packed runs copied from its pack buffers,
// and runs past a small pack buffer left to the display thread, show the same set; and
// queries sent from the display thread meanwhile do not wait for the state lock.
#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include <gtest/gtest.h>

#include "gauss/client/client_runtime.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "../engine/synthetic_test_scene.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

class ClientRuntimeInProcess : public VkTest {
 protected:
  // pack_slots: 0 = publication on the display thread; else on the publication thread
  // with pack buffers of that many slots. scatter_min_regions: the renderer's upload
  // scatter threshold (0: every upload group goes through the compute scatter).
  void converge_and_compare(std::uint32_t pack_slots,
                            std::uint32_t scatter_min_regions = vk::kDeviceScatterMinRegions);
  // A synthetic room of n Gaussians (with a surface: `surface`) produced into scene_, and
  // codec parameters boxing it.
  void make_room(std::size_t n, bool surface) {
    SyntheticSceneConfig sc = small_synthetic_config(n, 3);
    sc.surface_chunk = surface;
    auto synth = SyntheticScene::create(sc);
    ASSERT_TRUE(synth.ok()) << synth.message();
    synth_.emplace(std::move(*synth));
    ASSERT_NO_FATAL_FAILURE(produce_all(*synth_, scene_));
    params_.box.min = synth_->room_min() - glm::vec3(0.5f);
    params_.box.max = synth_->room_max() + glm::vec3(0.5f);
  }
  // The runtime's Hello to `host` and the host's answers (Welcome, scene info, surface).
  void welcome(client::ClientRuntime& rt, HostSession& host, double now) {
    const msg::Hello hello = rt.with_state([](const ClientState& s) { return s.hello(); });
    for (const auto& m : host.on_message(wire::Message{hello}, scene_, now)) rt.deliver(m);
  }

  std::optional<SyntheticScene> synth_;
  SceneStore scene_;
  CodecParams params_;
};

void ClientRuntimeInProcess::converge_and_compare(std::uint32_t pack_slots, std::uint32_t scatter_min_regions) {
  ASSERT_NO_FATAL_FAILURE(make_room(6000, true));  // a surface for the mesh pass
  CodecParams params = params_;
  params.sh_degree = 1;

  constexpr std::uint32_t kM = 2500;
  double now = 0.0;
  client::ClientRuntimeConfig cfg;
  cfg.state.capacity = kM;
  cfg.state.publisher.mode = PublishMode::Progressive;
  cfg.state.publisher.allowance_initial = 400;  // several frames of publication
  cfg.state.publisher.allowance_min = 400;
  cfg.state.publisher.allowance_max = 400;
  cfg.max_width = 160;
  cfg.max_height = 120;
  cfg.clock = [&now] { return now; };
  cfg.publication_thread = pack_slots > 0;
  cfg.pack_slots_per_step = pack_slots;
  cfg.upload_scatter_min_regions = scatter_min_regions;
  auto rt = client::ClientRuntime::create(context(), cfg);
  ASSERT_TRUE(rt.ok()) << rt.message();

  HostSession host(1, 42, params);
  welcome(**rt, host, now);
  const Camera cam = synth_->overview_camera(160, 120);
  int frames = 0;
  std::size_t pending = 1;
  std::uint64_t packed = 0, written = 0, scattered = 0;
  for (; frames < 400 && (pending > 0 || frames < 3); ++frames) {
    now += 1.0 / 72.0;
    auto out = host.tick(scene_, now);
    ASSERT_TRUE(out.ok()) << out.message();
    for (const auto& m : *out) (*rt)->deliver(m);
    auto f = (*rt)->frame(std::span<const Camera>(&cam, 1));
    ASSERT_TRUE(f.ok()) << f.message();
    for (const auto& m : (*rt)->take_outgoing())
      for (const auto& reply : host.on_message(m, scene_, now)) (*rt)->deliver(reply);
    EXPECT_EQ(f->publication_threaded, pack_slots > 0);
    packed += f->uploaded.slots_packed;
    written += f->uploaded.slots_written;
    scattered += f->scatter_regions;
    pending = f->pending + (f->published_epoch ? 0 : 1);
  }
  ASSERT_LT(frames, 400) << "did not converge";
  if (scatter_min_regions == 0) {
    // Every group scattered but those the scatter cannot take: the mesh chunks' vertex
    // and index buffers have no storage usage.
    EXPECT_GT(scattered, 0u);
    const vk::StagedUploadStats& up = (*rt)->renderer().uploads().stats();
    EXPECT_EQ(up.copy_groups, up.scatter_fallbacks);
  }
  EXPECT_GT(frames, 6) << "progressive publication at 400 edits per frame needs several frames for 2500";
  if (pack_slots == 0) {
    EXPECT_EQ(packed, 0u);
  } else {
    // A frame that took a step writing nothing: the slot table the next check reads under
    // the lock is the one on screen (the step it asked for has nothing left to publish).
    bool quiet = false;
    for (int k = 0; k < 100 && !quiet; ++k) {
      now += 1.0 / 72.0;
      auto f = (*rt)->frame(std::span<const Camera>(&cam, 1));
      ASSERT_TRUE(f.ok()) << f.message();
      quiet = f->step_taken && f->publish.slot_writes() == 0 && f->pending == 0;
    }
    ASSERT_TRUE(quiet);
    EXPECT_GT(packed, 0u) << "runs went through the pack buffers";
    if (pack_slots < 400) EXPECT_LT(packed, written) << "runs past the pack buffer went the display thread's way";
    else EXPECT_EQ(packed, written);
  }
  ASSERT_TRUE((*rt)->wait_frames().ok());

  // The published set is what the host sent.
  const std::uint64_t published = (*rt)->with_state([](const ClientState& s) { return s.published_checksum(); });
  EXPECT_EQ(published, host.sent_checksum());
  EXPECT_GT((*rt)->publication().stats().write_calls, 0u);

  // The frame equals a blocking renderer's image of the same slots and surface.
  auto actual = (*rt)->renderer().read_image();
  ASSERT_TRUE(actual.ok()) << actual.message();
  auto ref = render::SplatRenderer::create(context(), {.capacity = kM, .sh_degree = 1, .max_width = 160, .max_height = 120});
  ASSERT_TRUE(ref.ok());
  (*rt)->with_state([&](const ClientState& s) {
    for (std::uint32_t k = 0; k < kM; ++k) {
      GaussianId id{0};
      if (s.slots().occupant(SlotIndex{k}, id)) {
        EXPECT_TRUE((*ref)->write_slot(SlotIndex{k}, s.slots().records()[k]).ok());
      }
    }
    for (const auto& [chunk_id, chunk] : s.surface().committed())
      EXPECT_TRUE((*ref)->set_mesh_chunk(chunk_id, chunk.mesh).ok());
    return 0;
  });
  EXPECT_GT((*ref)->mesh_chunk_count(), 0u) << "the surface reached the client";
  ASSERT_TRUE((*ref)->render(cam).ok());
  auto expected = (*ref)->read_image();
  ASSERT_TRUE(expected.ok());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < expected->pixels.size(); ++i) differ += expected->pixels[i] != actual->pixels[i];
  EXPECT_EQ(differ, 0u);
}

TEST_F(ClientRuntimeInProcess, ConvergesToTheSentSetAndRendersItExactly) { converge_and_compare(0); }

TEST_F(ClientRuntimeInProcess, PublicationThreadShowsTheSameSet) { converge_and_compare(4096); }

TEST_F(ClientRuntimeInProcess, PublicationThreadWithASmallPackBufferShowsTheSameSet) { converge_and_compare(150); }

// The same through StagedUploads' compute scatter (slot runs, clears, the pack buffers'
// runs): publication fills slots in long runs here, under the default threshold.
TEST_F(ClientRuntimeInProcess, EveryUploadScatteredShowsTheSameSet) { converge_and_compare(0, 0); }

TEST_F(ClientRuntimeInProcess, PublicationThreadWithEveryUploadScatteredShowsTheSameSet) {
  converge_and_compare(150, 0);
}

// Lock step (ClientRuntimeConfig::publication_lockstep, gauss-eval's stereo timing): the
// step asked for in one frame reaches the next, always, so two runs over the same
// messages publish the same edits frame for frame, and the set converges to what the
// host sent.
TEST_F(ClientRuntimeInProcess, LockStepPublicationIsOneFrameLateAndDeterministic) {
  ASSERT_NO_FATAL_FAILURE(make_room(6000, false));
  CodecParams params = params_;
  params.sh_degree = 1;
  const Camera cam = synth_->overview_camera(160, 120);
  struct Run {
    std::vector<std::uint64_t> writes;  // slot writes per frame
    std::uint64_t published{0}, sent{0};
  };
  auto run = [&]() -> Run {
    Run r;
    double now = 0.0;
    client::ClientRuntimeConfig cfg;
    cfg.state.capacity = 2500;
    cfg.state.publisher.mode = PublishMode::Progressive;
    cfg.state.publisher.allowance_initial = cfg.state.publisher.allowance_min = cfg.state.publisher.allowance_max = 400;
    cfg.max_width = 160;
    cfg.max_height = 120;
    cfg.clock = [&now] { return now; };
    cfg.publication_thread = cfg.publication_lockstep = true;
    auto rt = client::ClientRuntime::create(context(), cfg);
    EXPECT_TRUE(rt.ok()) << rt.message();
    if (!rt.ok()) return r;
    HostSession host(1, 42, params);
    welcome(**rt, host, now);
    for (int frame = 0; frame < 60; ++frame) {
      now += 1.0 / 72.0;
      auto out = host.tick(scene_, now);
      EXPECT_TRUE(out.ok()) << out.message();
      if (!out.ok()) return r;
      for (const auto& m : *out) (*rt)->deliver(m);
      auto f = (*rt)->frame(std::span<const Camera>(&cam, 1));
      EXPECT_TRUE(f.ok()) << f.message();
      if (!f.ok()) return r;
      EXPECT_EQ(f->step_taken, frame > 0) << "frame " << frame << ": the step asked for last frame is this frame's";
      r.writes.push_back(f->publish.slot_writes());
      for (const auto& m : (*rt)->take_outgoing())
        for (const auto& reply : host.on_message(m, scene_, now)) (*rt)->deliver(reply);
    }
    EXPECT_TRUE((*rt)->wait_frames().ok());
    r.published = (*rt)->with_state([](const ClientState& s) { return s.published_checksum(); });
    r.sent = host.sent_checksum();
    return r;
  };
  const Run a = run();
  const Run b = run();
  ASSERT_EQ(a.writes.size(), 60u);
  EXPECT_EQ(a.writes, b.writes) << "the same messages, the same edits per frame";
  EXPECT_GT(std::count_if(a.writes.begin(), a.writes.end(), [](std::uint64_t w) { return w > 0; }), 5)
      << "progressive publication at 400 edits per frame spreads over frames";
  EXPECT_EQ(a.published, a.sent) << "converged to the sent set within 60 frames";
  EXPECT_EQ(a.published, b.published);
}

// With the publication thread, a query and a mode change from the display thread never
// wait for the state lock (a running step holds it for its whole length): the id is
// reserved at once and both reach ClientState with the next step, in order. Here another
// thread holds the lock while the display thread sends; it lets go only when the sends
// returned (or after 10 s, which the test reports as a wait).
TEST_F(ClientRuntimeInProcess, IntentFromTheDisplayThreadDoesNotWaitForTheStateLock) {
  ASSERT_NO_FATAL_FAILURE(make_room(2000, false));
  double now = 0.0;
  client::ClientRuntimeConfig cfg;
  cfg.state.capacity = 1000;
  cfg.state.publisher.mode = PublishMode::Progressive;
  cfg.max_width = 64;
  cfg.max_height = 48;
  cfg.clock = [&now] { return now; };
  cfg.publication_thread = true;
  auto rt = client::ClientRuntime::create(context(), cfg);
  ASSERT_TRUE(rt.ok()) << rt.message();
  HostSession host(1, 42, params_);
  welcome(**rt, host, now);
  const Camera cam = synth_->overview_camera(64, 48);

  std::mutex mu;
  std::condition_variable cv;
  bool holding = false, sent = false, released_by_sender = false;
  std::thread holder([&] {
    (*rt)->with_state([&](const ClientState&) {
      std::unique_lock lock(mu);
      holding = true;
      cv.notify_all();
      released_by_sender = cv.wait_for(lock, std::chrono::seconds(10), [&] { return sent; });
      return 0;
    });
  });
  {
    std::unique_lock lock(mu);
    cv.wait(lock, [&] { return holding; });
  }
  msg::Query q;
  q.kind = msg::QueryKind::Instance;
  q.instance = ObjectId{1};
  q.rho = 0.5f;
  const std::uint32_t first = (*rt)->send_query(q);
  const std::uint32_t second = (*rt)->send_query(q);
  (*rt)->set_publish_mode(PublishMode::Immediate);
  {
    std::lock_guard lock(mu);
    sent = true;
  }
  cv.notify_all();
  holder.join();
  EXPECT_TRUE(released_by_sender) << "send_query or set_publish_mode waited for the state lock";
  EXPECT_EQ(second, first + 1);

  // The next steps hand both queries to the host, in order, and switch the mode.
  std::vector<std::uint32_t> sent_ids;
  for (int frames = 0; frames < 20 && sent_ids.size() < 2; ++frames) {
    now += 1.0 / 72.0;
    auto f = (*rt)->frame(std::span<const Camera>(&cam, 1));
    ASSERT_TRUE(f.ok()) << f.message();
    ASSERT_TRUE((*rt)->wait_frames().ok());
    for (const auto& m : (*rt)->take_outgoing())
      if (const auto* query = std::get_if<msg::Query>(&m)) sent_ids.push_back(query->query_id);
  }
  EXPECT_EQ(sent_ids, (std::vector<std::uint32_t>{first, second}));
  EXPECT_EQ((*rt)->with_state([](const ClientState& s) { return s.publisher().config().mode; }), PublishMode::Immediate);
}

}  // namespace
}  // namespace gauss::test
