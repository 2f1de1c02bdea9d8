// HostSession with LoD on, followed by a ClientState: the client ends with exactly the cut
// the host sent (interior records included), within M; at M >= N the stream is byte for byte
// the leaf selection's; an unchanged epoch sends nothing; an edit inside one object updates
// only records of its subtree and the nodes above it; a query's share stays exact.
#include <algorithm>
#include <map>
#include <cmath>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/client_state.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/host_session.h"
#include "address_space_limit.h"
#include "host_world.h"

using namespace gauss;

namespace {

using World = gauss::test::HostWorld;

HostSessionConfig lod_config(bool on) {
  HostSessionConfig c;
  if (on) c.lod = LodConfig{};
  return c;
}

CodecParams lod_params(const World& w) {
  return fit_lod_codec_params(w.params);
}

// A host session and its client, connected, with everything the first tick sent settled.
struct Pair {
  HostSession host;
  ClientState client;
};

Pair connect(World& w, const CodecParams& params, const HostSessionConfig& config, std::uint32_t capacity) {
  HostSession host(1, 9, params, config);
  ClientConfig cfg;
  cfg.capacity = capacity;
  auto client = ClientState::create(0, cfg);
  EXPECT_TRUE(client.ok());
  for (const auto& m : host.on_message(client->hello(), w.store, 0.0)) EXPECT_TRUE(client->on_message(m, 0.0).ok());
  return Pair{std::move(host), std::move(*client)};
}
Pair connect(World& w, const CodecParams& params, bool lod, std::uint32_t capacity) {
  return connect(w, params, lod_config(lod), capacity);
}

// Ticks the host at t, delivers, displays until nothing is pending; returns the batches'
// edits (decoded with the session's codec) and the raw payloads.
struct Step {
  std::vector<Edit> edits;
  std::vector<std::vector<std::uint8_t>> payloads;
};
Step step(Pair& p, World& w, const CodecParams& params, double t) {
  Step s;
  auto out = p.host.tick(w.store, t);
  EXPECT_TRUE(out.ok()) << out.message();
  if (!out.ok()) return s;
  for (const auto& m : *out) {
    if (const auto* b = std::get_if<msg::EditBatchMsg>(&m)) {
      auto batch = decode_edit_batch(b->payload, params);
      EXPECT_TRUE(batch.ok()) << batch.message();
      if (batch.ok()) s.edits.insert(s.edits.end(), batch->edits.begin(), batch->edits.end());
      s.payloads.push_back(b->payload);
    }
    EXPECT_TRUE(p.client.on_message(m, t).ok());
  }
  for (std::uint64_t f = 0; f < 400 && p.client.desired().pending_count() > 0; ++f) {
    EXPECT_TRUE(p.client.frame(ViewState{}, t, f).ok());
    p.client.frame_rendered(t, f);
  }
  EXPECT_TRUE(p.client.check().ok()) << p.client.check().message();
  EXPECT_EQ(p.client.desired().pending_count(), 0u);
  for (const auto& m : p.client.take_outgoing()) (void)p.host.on_message(m, w.store, t);
  return s;
}

std::size_t interior_count(const std::vector<GaussianId>& ids) {
  return static_cast<std::size_t>(std::count_if(ids.begin(), ids.end(), is_lod_interior_id));
}

// Ids of every interior node in the subtree at pool node n.
void interior_under(const LodHierarchy& h, std::uint32_t n, std::set<GaussianId>& out) {
  const LodNode& node = h.node(n);
  if (node.leaf) return;
  out.insert(node.id);
  for (std::uint32_t c : h.children(node)) interior_under(h, c, out);
}

}  // namespace

TEST(HostSessionLod, TheClientHoldsExactlyTheSentCutWithinTheBudget) {
  World w;
  const CodecParams params = lod_params(w);
  const std::uint32_t m = 250;  // N = 2000: an eighth
  Pair p = connect(w, params, true, m);
  step(p, w, params, 0.0);
  const auto& sent = p.host.sent_ids();
  EXPECT_LE(sent.size(), m);
  EXPECT_GT(interior_count(sent), 0u) << "M = N/8 must send interior records";
  EXPECT_EQ(p.client.published_checksum(), p.client.desired().desired_checksum());
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
  // Every sent interior id is a live node of the session's hierarchy.
  for (GaussianId id : sent)
    if (is_lod_interior_id(id)) {
      ASSERT_NE(p.host.lod()->find_interior(id), nullptr);
    }
}

TEST(HostSessionLod, WhereEverythingFitsTheStreamIsTheLeafSelectionsByteForByte) {
  World w;
  const CodecParams params = lod_params(w);
  const std::uint32_t m = 3000;  // > N
  Pair on = connect(w, params, true, m);
  Pair off = connect(w, params, false, m);
  const Step a = step(on, w, params, 0.0);
  const Step b = step(off, w, params, 0.0);
  EXPECT_EQ(a.payloads, b.payloads);
  EXPECT_EQ(on.host.sent_ids(), off.host.sent_ids());
  EXPECT_EQ(interior_count(on.host.sent_ids()), 0u);
  EXPECT_EQ(on.client.published_checksum(), off.client.published_checksum());
}

TEST(HostSessionLod, AnUnchangedEpochSendsNoEdit) {
  World w;
  const CodecParams params = lod_params(w);
  Pair p = connect(w, params, true, 250);
  step(p, w, params, 0.0);
  const std::vector<GaussianId> before = p.host.sent_ids();
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  const Step s = step(p, w, params, 1.0);
  EXPECT_EQ(s.payloads.size(), 1u) << "a new epoch always gets its batch";
  EXPECT_TRUE(s.edits.empty());
  EXPECT_EQ(p.host.sent_ids(), before) << "interior ids are stable";
}

TEST(HostSessionLod, AnEditInsideOneObjectUpdatesOnlyItsSubtreeAndTheNodesAboveIt) {
  World w;
  const CodecParams params = lod_params(w);
  Pair p = connect(w, params, true, 250);
  step(p, w, params, 0.0);
  const LodHierarchy* h = p.host.lod()->hierarchy();
  ASSERT_NE(h, nullptr);
  // The object with the most Gaussians; its subtree and the path above it, before the edit.
  std::map<std::int32_t, int> count;
  for (const Gaussian& g : w.store.gaussians())
    if (to_underlying(g.object) >= 0) ++count[to_underlying(g.object)];
  const ObjectId o{std::max_element(count.begin(), count.end(), [](auto& a, auto& b) { return a.second < b.second; })->first};
  std::set<GaussianId> allowed;
  const std::uint32_t root = h->object_root(o);
  ASSERT_NE(root, kNoLodNode);
  interior_under(*h, root, allowed);
  for (std::uint32_t n = h->node(root).parent; n != kNoLodNode; n = h->node(n).parent) allowed.insert(h->node(n).id);
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  std::vector<GaussianId> moved;
  for (const Gaussian& g : w.store.gaussians()) {
    if (g.object != o) continue;
    Gaussian c = g;
    c.sh_dc += glm::vec3(0.3f);  // recoloured in place: the tree's shape stays
    moved.push_back(c.id);
    ASSERT_TRUE(w.store.modify(c).ok());
  }
  ASSERT_TRUE(w.store.commit_epoch().ok());
  std::sort(moved.begin(), moved.end());
  const Step s = step(p, w, params, 1.0);
  std::size_t interior_updates = 0;
  for (const Edit& e : s.edits) {
    if (e.kind != EditKind::Update) continue;
    if (is_lod_interior_id(e.id)) {
      ++interior_updates;
      EXPECT_TRUE(allowed.count(e.id)) << "interior " << to_underlying(e.id) << " is outside the object's subtree";
    } else {
      EXPECT_TRUE(std::binary_search(moved.begin(), moved.end(), e.id)) << "leaf " << to_underlying(e.id);
    }
  }
  EXPECT_GT(interior_updates, 0u) << "the recoloured object's coarse records must follow it";
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
}

TEST(HostSessionLod, AQuerysShareStaysExactInLeaves) {
  World w;
  const CodecParams params = lod_params(w);
  const std::uint32_t m = 300;
  Pair p = connect(w, params, true, m);
  step(p, w, params, 0.0);
  const ObjectId o = w.store.objects().front().id;
  std::size_t members = 0;
  for (const Gaussian& g : w.store.gaussians()) members += g.object == o && !g.carrier;
  msg::Query q;
  q.kind = msg::QueryKind::Instance;
  q.instance = o;
  q.rho = 0.5f;
  ASSERT_EQ(std::get<msg::QueryReply>(p.host.on_message(q, w.store, 1.0)[0]).status, msg::QueryStatus::Resolved);
  step(p, w, params, 1.0);
  std::size_t target_leaves = 0;
  for (GaussianId id : p.host.sent_ids()) {
    const std::optional<Gaussian> g = p.host.sent_record(id);
    ASSERT_TRUE(g.has_value());
    if (is_lod_interior_id(id)) {
      EXPECT_NE(g->object, o) << "a coarse record stands for the target";
    } else {
      target_leaves += g->object == o;
    }
  }
  EXPECT_EQ(target_leaves, std::min<std::size_t>(members, std::size_t(std::floor(0.5 * m))));
  EXPECT_LE(p.host.sent_ids().size(), m);
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
}

TEST(HostSessionLod, AGaussianTheHierarchyRefusesMeansLeavesWithOneNoticeUntilItIsGone) {
  // An id with the top bit set is an interior node's id space: the hierarchy refuses it, the
  // session falls back to leaf selection (the client stays exact) and says so once, not once
  // per epoch; when the Gaussian goes, the cut comes back.
  World w;
  const CodecParams params = lod_params(w);
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  Gaussian odd = w.store.gaussians()[0];
  odd.id = GaussianId{kLodInteriorIdBit | 5};
  odd.log_scale += glm::vec3(2.0f);  // large and opaque: the leaf selection takes it
  odd.opacity_logit = 6.0f;
  ASSERT_TRUE(w.store.insert(odd).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  Pair p = connect(w, params, true, 250);
  step(p, w, params, 0.0);
  EXPECT_EQ(interior_count(p.host.sent_ids()), 1u) << "the odd Gaussian itself, as a leaf";
  const auto first = p.host.take_notices();
  ASSERT_EQ(first.size(), 1u);
  EXPECT_NE(first[0].find("top bit"), std::string::npos) << first[0];
  EXPECT_EQ(p.host.stats().lod_fallbacks, 1u);
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
  for (int e = 0; e < 2; ++e) {  // the cause stays: no new notice
    ASSERT_TRUE(w.store.begin_next_epoch().ok());
    ASSERT_TRUE(w.store.commit_epoch().ok());
    step(p, w, params, 1.0 + e);
    EXPECT_TRUE(p.host.take_notices().empty());
  }
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.remove(odd.id).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  step(p, w, params, 5.0);
  EXPECT_GT(interior_count(p.host.sent_ids()), 1u) << "the cut is back";
  EXPECT_LE(p.host.sent_ids().size(), 250u);
  EXPECT_EQ(p.client.published_checksum(), p.client.desired().desired_checksum());
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
}

TEST(HostSessionLod, SessionsSharingOneHierarchyStreamWhatEachWouldWithItsOwn) {
  // Two sessions read one LodEpochHierarchy (as SessionHost's do), two others have their own.
  // Epoch after epoch an object is recoloured (its coarse records change, the tree's shape
  // stays). One shared session ticks every epoch; the other sits out more epochs than the
  // shared log keeps, as a session held back by its link would, then catches up in one batch.
  // Each must send byte for byte what a session with its own hierarchy on the same schedule
  // sends, and its client must end exact.
  World w;
  const CodecParams params = lod_params(w);
  const std::uint32_t m = 250;
  auto shared = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  HostSessionConfig shared_config = lod_config(true);
  shared_config.shared_lod = shared;
  Pair every_own = connect(w, params, true, m);
  Pair late_own = connect(w, params, true, m);
  Pair every_shared = connect(w, params, shared_config, m);
  Pair late_shared = connect(w, params, shared_config, m);
  EXPECT_EQ(step(every_shared, w, params, 0.0).payloads, step(every_own, w, params, 0.0).payloads);
  EXPECT_EQ(step(late_shared, w, params, 0.0).payloads, step(late_own, w, params, 0.0).payloads);
  ASSERT_NE(every_shared.host.lod()->hierarchy(), nullptr);
  EXPECT_EQ(every_shared.host.lod()->hierarchy(), late_shared.host.lod()->hierarchy()) << "one hierarchy";
  EXPECT_NE(every_own.host.lod()->hierarchy(), late_own.host.lod()->hierarchy());
  EXPECT_EQ(shared->updates(), 1u) << "built once for both sessions";

  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  ASSERT_FALSE(objects.empty());
  const std::size_t epochs = LodEpochHierarchy::kLogLength + 3;
  std::size_t interior_updates = 0;
  for (std::size_t e = 0; e < epochs; ++e) {
    ASSERT_TRUE(w.store.begin_next_epoch().ok());
    const ObjectId o = objects[e % objects.size()];
    for (const Gaussian& g : w.store.gaussians()) {
      if (g.object != o) continue;
      Gaussian c = g;
      c.sh_dc = glm::vec3(0.05f * float(e % 7), 0.3f, -0.2f);
      ASSERT_TRUE(w.store.modify(c).ok());
    }
    ASSERT_TRUE(w.store.commit_epoch().ok());
    const double t = 1.0 + double(e);
    const Step a = step(every_shared, w, params, t);
    const Step b = step(every_own, w, params, t);
    EXPECT_EQ(a.payloads, b.payloads) << "epoch step " << e;
    for (const Edit& edit : a.edits) interior_updates += edit.kind == EditKind::Update && is_lod_interior_id(edit.id);
  }
  EXPECT_GT(interior_updates, 0u) << "recolouring must reach the coarse records";
  EXPECT_EQ(shared->updates(), 1u + epochs);
  const double t = 1.0 + double(epochs);
  const Step late_a = step(late_shared, w, params, t);
  const Step late_b = step(late_own, w, params, t);
  EXPECT_EQ(late_a.payloads, late_b.payloads) << "a session past the log's reach catches up all the same";
  for (Pair* p : {&every_shared, &late_shared}) {
    EXPECT_EQ(p->client.published_checksum(), p->client.desired().desired_checksum());
    EXPECT_EQ(p->client.desired().desired_checksum(), p->host.sent_checksum());
  }
  EXPECT_GT(interior_count(late_shared.host.sent_ids()), 0u);
}

namespace {

// One epoch of churn: object `o` recoloured, the first live Gaussian of another object
// removed, and a copy of one of o's Gaussians inserted, moved by `shift`.
void churn_epoch(World& w, ObjectId o, int e) {
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  const Gaussian* removed = nullptr;
  const Gaussian* template_g = nullptr;
  for (const Gaussian& g : w.store.gaussians()) {
    if (g.carrier || !w.store.contains(g.id)) continue;
    if (g.object != o && !removed) removed = &g;
    if (g.object == o && !template_g) template_g = &g;
  }
  ASSERT_NE(removed, nullptr);
  ASSERT_NE(template_g, nullptr);
  Gaussian fresh = *template_g;
  fresh.id = w.store.allocate_id();
  fresh.position += glm::vec3(0.01f * float(e % 5), 0.02f, -0.01f);
  const GaussianId gone = removed->id;
  std::vector<Gaussian> recoloured;
  for (const Gaussian& g : w.store.gaussians())
    if (g.object == o && w.store.contains(g.id)) {
      Gaussian c = g;
      c.sh_dc = glm::vec3(0.05f * float(e % 7), 0.3f, -0.2f);
      recoloured.push_back(c);
    }
  for (const Gaussian& c : recoloured) ASSERT_TRUE(w.store.modify(c).ok());
  ASSERT_TRUE(w.store.remove(gone).ok());
  ASSERT_TRUE(w.store.insert(fresh).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
}

// A session that only reads a hierarchy its host updates in the background.
HostSessionConfig following(std::shared_ptr<LodEpochHierarchy> hierarchy) {
  HostSessionConfig c = lod_config(true);
  c.shared_lod = std::move(hierarchy);
  c.lod_in_background = true;
  return c;
}

// Drives a background hierarchy to the scene's epoch as a host loop does: start, wait, take up.
void settle_background(LodEpochHierarchy& h, const SceneStore& scene) {
  for (int k = 0; k < 4; ++k) {
    auto p = h.update_in_background(scene, nullptr);
    ASSERT_TRUE(p.ok()) << p.message();
    if (*p == LodEpochHierarchy::Progress::Ready) return;
    h.wait_idle();
  }
  FAIL() << "the background update never became ready";
}

// The summary a host logs of the update last taken up (SessionHost says a build): for the
// scene's epoch, with the hierarchy's figures; a build compares the whole span, a later
// epoch follows the change log.
void expect_last_update(const LodEpochHierarchy& h, const SceneStore& scene, bool built) {
  const auto last = h.last_update();
  ASSERT_TRUE(last.has_value());
  EXPECT_EQ(last->built, built);
  EXPECT_EQ(last->from_change_log, !built);
  EXPECT_EQ(last->epoch, scene.epoch());
  EXPECT_EQ(last->leaves, h.hierarchy()->leaf_count());
  EXPECT_EQ(last->interior, h.hierarchy()->interior_count());
  EXPECT_GT(last->leaves, 0u);
  EXPECT_GT(last->seconds, 0.0);
}

}  // namespace

TEST(HostSessionLod, SessionsFollowingABackgroundHierarchyStreamWhatASynchronousOneSends) {
  // SessionHost updates its hierarchy on a worker thread and its sessions only follow it. A
  // session must send nothing while the update is at work, and afterwards byte for byte what a
  // session updating its hierarchy itself sends. Every other epoch the scene moves on while the
  // worker still reads the last one (the job's copy of the scene is what it must read): the
  // session then waits for the second update too.
  World w;
  const CodecParams params = lod_params(w);
  const std::uint32_t m = 250;
  auto background = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  auto inline_h = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  const HostSessionConfig follows = following(background);
  HostSessionConfig updates_itself = lod_config(true);
  updates_itself.shared_lod = inline_h;
  Pair a = connect(w, params, follows, m);
  Pair b = connect(w, params, updates_itself, m);

  auto quiet = [&](Pair& p, double t) {
    auto out = p.host.tick(w.store, t);
    ASSERT_TRUE(out.ok()) << out.message();
    EXPECT_TRUE(out->empty()) << "a session must wait for the hierarchy of its epoch";
  };
  auto started = background->update_in_background(w.store, nullptr);
  ASSERT_TRUE(started.ok());
  EXPECT_EQ(*started, LodEpochHierarchy::Progress::Working) << "the first build runs on the worker";
  EXPECT_TRUE(background->busy());
  quiet(a, 0.0);
  background->wait_idle();
  EXPECT_TRUE(background->busy()) << "finished but not taken up";
  quiet(a, 0.0);
  settle_background(*background, w.store);
  EXPECT_FALSE(background->busy());
  EXPECT_EQ(step(a, w, params, 0.0).payloads, step(b, w, params, 0.0).payloads);
  ASSERT_GT(interior_count(a.host.sent_ids()), 0u);
  expect_last_update(*background, w.store, /*built=*/true);

  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  ASSERT_FALSE(objects.empty());
  std::size_t interior_updates = 0;
  for (int e = 0; e < 8; ++e) {
    churn_epoch(w, objects[std::size_t(e) % objects.size()], e);
    ASSERT_TRUE(inline_h->update(w.store, nullptr).ok());
    auto p = background->update_in_background(w.store, nullptr);
    ASSERT_TRUE(p.ok()) << p.message();
    ASSERT_EQ(*p, LodEpochHierarchy::Progress::Working);
    const double t = 1.0 + e;
    if (e % 2 == 1) {
      // The scene moves on while the worker may still read the epoch before.
      churn_epoch(w, objects[std::size_t(e + 3) % objects.size()], e + 100);
      ASSERT_TRUE(inline_h->update(w.store, nullptr).ok());
      background->wait_idle();
      auto next = background->update_in_background(w.store, nullptr);
      ASSERT_TRUE(next.ok()) << next.message();
      EXPECT_EQ(*next, LodEpochHierarchy::Progress::Working) << "the scene's new epoch is the next job";
    }
    quiet(a, t);
    settle_background(*background, w.store);
    const Step sa = step(a, w, params, t);
    const Step sb = step(b, w, params, t);
    EXPECT_EQ(sa.payloads, sb.payloads) << "epoch step " << e;
    EXPECT_FALSE(sa.payloads.empty());
    for (const Edit& edit : sa.edits) interior_updates += edit.kind == EditKind::Update && is_lod_interior_id(edit.id);
  }
  EXPECT_GT(interior_updates, 0u) << "the churn must reach the coarse records";
  EXPECT_EQ(background->updates(), inline_h->updates());
  expect_last_update(*background, w.store, /*built=*/false);
  EXPECT_EQ(a.client.published_checksum(), a.client.desired().desired_checksum());
  EXPECT_EQ(a.client.desired().desired_checksum(), a.host.sent_checksum());
}

TEST(HostSessionLod, TheBackgroundUpdateBuildsTheCutLayoutSoTheFirstCutFindsIt) {
  // The cutters' breadth-first copy of a new tree is built on the worker after its update:
  // built by the first cut after it, it stalled a host's serving thread 0.1-0.4 s per epoch
  // at a million leaves. Before any reader has cut there is none to keep up (clients whose
  // budgets hold every leaf never cut).
  World w;
  const CodecParams params = lod_params(w);
  auto background = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  Pair a = connect(w, params, following(background), 250);
  const auto& layouts = *background->layouts();
  settle_background(*background, w.store);
  EXPECT_EQ(layouts.builds(), 0u) << "no reader has cut yet";
  ASSERT_FALSE(step(a, w, params, 0.0).payloads.empty());
  ASSERT_EQ(layouts.builds(), 1u) << "the first cut builds the first layout";
  ASSERT_GT(interior_count(a.host.sent_ids()), 0u) << "the session must cut for this test to mean anything";
  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  ASSERT_FALSE(objects.empty());
  for (int e = 0; e < 3; ++e) {
    churn_epoch(w, objects[std::size_t(e) % objects.size()], e);
    settle_background(*background, w.store);
    EXPECT_EQ(layouts.builds(), 2u + std::uint64_t(e)) << "epoch step " << e << ": built with the update";
    EXPECT_FALSE(step(a, w, params, 1.0 + e).payloads.empty());
    EXPECT_EQ(layouts.builds(), 2u + std::uint64_t(e)) << "epoch step " << e << ": the cut took the prepared one";
  }
  EXPECT_EQ(a.client.desired().desired_checksum(), a.host.sent_checksum());
}

TEST(HostSessionLod, ASessionsRecordIsWhatItSentHoweverTheSceneAndHierarchyMoveOnAfter) {
  // gauss-host reports a leaving client's set (--sessions, --dump-sent) after its last batch.
  // A new epoch may have arrived by then, and a background update may already have rewritten
  // the hierarchy's records in place: what the session says it sent must still be what the
  // client holds, record for record.
  World w;
  const CodecParams params = lod_params(w);
  auto background = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  const HostSessionConfig follows = following(background);
  Pair p = connect(w, params, follows, 250);
  settle_background(*background, w.store);
  step(p, w, params, 0.0);
  ASSERT_GT(interior_count(p.host.sent_ids()), 0u);
  const std::uint64_t held = p.client.published_checksum();
  ASSERT_EQ(held, p.host.sent_checksum());

  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  ASSERT_GE(objects.size(), 2u);
  for (int e = 0; e < 2; ++e) churn_epoch(w, objects[std::size_t(e)], e);
  settle_background(*background, w.store);  // the hierarchy now stands for an epoch never sent
  EXPECT_EQ(p.host.sent_checksum(), held) << "the record of what was sent moved with the scene";
  std::size_t moved = 0;
  for (GaussianId id : p.host.sent_ids()) {
    const std::optional<Gaussian> sent = p.host.sent_record(id);
    ASSERT_TRUE(sent.has_value());
    const SlotIndex slot = p.client.slots().slot_of(id);
    ASSERT_NE(slot, kNoSlot);
    EXPECT_EQ(record_hash(id, *sent), record_hash(id, p.client.slots().records()[to_underlying(slot)]));
    const Gaussian* now = is_lod_interior_id(id) ? p.host.lod()->find_interior(id) : w.store.find(id);
    moved += !now || !same_value(quantize_roundtrip(*now, params), *sent);
  }
  EXPECT_GT(moved, 0u) << "the churn must change sent records, or this test shows nothing";
  // The next tick sends the epoch, and the record follows.
  step(p, w, params, 1.0);
  EXPECT_EQ(p.client.published_checksum(), p.host.sent_checksum());
  EXPECT_NE(p.host.sent_checksum(), held);
}

TEST(HostSessionLod, ABackgroundUpdateThatFailsIsSaidOnceAndLeavesAreSelected) {
  // The refused Gaussian of the test above, through the worker: the failure comes back from
  // the call that takes the update up, once; the hierarchy is then dropped (readers select
  // leaves, the client stays exact); a later epoch with the same cause is quiet, and once the
  // Gaussian is gone the cut comes back.
  World w;
  const CodecParams params = lod_params(w);
  auto background = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  const HostSessionConfig follows = following(background);
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  Gaussian odd = w.store.gaussians()[0];
  odd.id = GaussianId{kLodInteriorIdBit | 5};
  odd.log_scale += glm::vec3(2.0f);
  odd.opacity_logit = 6.0f;
  ASSERT_TRUE(w.store.insert(odd).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  Pair p = connect(w, params, follows, 250);
  ASSERT_EQ(*background->update_in_background(w.store, nullptr), LodEpochHierarchy::Progress::Working);
  background->wait_idle();
  auto failed = background->update_in_background(w.store, nullptr);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.message().find("top bit"), std::string::npos) << failed.message();
  EXPECT_FALSE(background->busy());
  ASSERT_EQ(*background->update_in_background(w.store, nullptr), LodEpochHierarchy::Progress::Ready);
  EXPECT_EQ(background->hierarchy(), nullptr);
  step(p, w, params, 0.0);
  EXPECT_EQ(interior_count(p.host.sent_ids()), 1u) << "the odd Gaussian itself, as a leaf";
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  ASSERT_EQ(*background->update_in_background(w.store, nullptr), LodEpochHierarchy::Progress::Working);
  background->wait_idle();
  auto quiet = background->update_in_background(w.store, nullptr);
  ASSERT_TRUE(quiet.ok()) << "the same cause is said once: " << quiet.message();
  EXPECT_EQ(*quiet, LodEpochHierarchy::Progress::Ready);
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.remove(odd.id).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  settle_background(*background, w.store);
  ASSERT_NE(background->hierarchy(), nullptr);
  step(p, w, params, 5.0);
  EXPECT_GT(interior_count(p.host.sent_ids()), 1u) << "the cut is back";
  EXPECT_LE(p.host.sent_ids().size(), 250u);
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
}

namespace {

// A background hierarchy that cannot run under `config`: there is nothing for a worker to do.
// The reason (containing `why`) is said once, the epoch counts as done (hierarchy() null), a
// following session selects leaves instead of waiting for an update that never comes, and the
// next epoch is quiet.
void expect_background_refusal(const LodConfig& config, const std::string& why) {
  World w;
  const CodecParams params = lod_params(w);
  auto background = std::make_shared<LodEpochHierarchy>(params.sh_degree, config);
  Pair p = connect(w, params, following(background), 250);
  auto first = background->update_in_background(w.store, nullptr);
  ASSERT_FALSE(first.ok());
  EXPECT_NE(first.message().find(why), std::string::npos) << first.message();
  EXPECT_FALSE(background->busy());
  EXPECT_EQ(background->progress(w.store), LodEpochHierarchy::Progress::Ready);
  EXPECT_EQ(background->hierarchy(), nullptr);
  const Step s = step(p, w, params, 0.0);
  EXPECT_FALSE(s.payloads.empty()) << "the session selects leaves";
  EXPECT_EQ(interior_count(p.host.sent_ids()), 0u);
  EXPECT_EQ(p.host.sent_ids().size(), 250u);
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
  auto again = background->update_in_background(w.store, nullptr);
  ASSERT_TRUE(again.ok()) << "said once: " << again.message();
  EXPECT_EQ(*again, LodEpochHierarchy::Progress::Ready);
}

}  // namespace

TEST(HostSessionLod, ABackgroundHierarchyThatCannotBeMadeLeavesNoSessionWaiting) {
  // A LodConfig the hierarchy refuses.
  LodConfig bad;
  bad.max_leaves_per_node = 1;
  expect_background_refusal(bad, "max_leaves_per_node");
}

TEST(HostSessionLod, AHierarchyTooLargeForItsMemoryIsRefusedBeforeItIsBuilt) {
  // LodConfig::max_bytes below what bytes_for() says of the scene (2000 Gaussians: about
  // 1.4 MB): nothing is built, the session selects leaves (the client stays exact) and says
  // why once, with the figures; later epochs are quiet.
  World w;
  const CodecParams params = lod_params(w);
  HostSessionConfig config = lod_config(true);
  config.lod->max_bytes = 300000;
  Pair p = connect(w, params, config, 250);
  step(p, w, params, 0.0);
  EXPECT_EQ(interior_count(p.host.sent_ids()), 0u);
  EXPECT_EQ(p.host.sent_ids().size(), 250u);
  const auto first = p.host.take_notices();
  ASSERT_EQ(first.size(), 1u);
  EXPECT_NE(first[0].find("not enough memory"), std::string::npos) << first[0];
  EXPECT_NE(first[0].find("needs about"), std::string::npos) << first[0];
  EXPECT_NE(first[0].find("more than the 300000 bytes allowed"), std::string::npos) << first[0];
  EXPECT_NE(first[0].find("selecting leaves"), std::string::npos) << first[0];
  EXPECT_EQ(p.host.stats().lod_fallbacks, 1u);
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
  for (int e = 0; e < 2; ++e) {
    ASSERT_TRUE(w.store.begin_next_epoch().ok());
    ASSERT_TRUE(w.store.commit_epoch().ok());
    step(p, w, params, 1.0 + e);
    EXPECT_TRUE(p.host.take_notices().empty()) << "said once";
  }
  EXPECT_EQ(p.client.desired().desired_checksum(), p.host.sent_checksum());
}

TEST(HostSessionLod, ABackgroundHierarchyTooLargeForItsMemoryLeavesNoSessionWaiting) {
  // The memory refusal through the worker: it comes before the scene is copied, so nothing
  // is posted.
  LodConfig small;
  small.max_bytes = 300000;
  expect_background_refusal(small, "not enough memory");
}

TEST(HostSessionLod, AnUpdateThatRunsOutOfMemoryDropsTheHierarchyNotTheHost) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan reserves more address space than the limit this test sets";
#else
  // A limit the estimate cannot see (an allowance above what the process may map here; in
  // the field, one no file says): the build's allocations fail partway. The update reports it as a
  // failure (the hierarchy dropped, leaves selected) instead of the exception ending the
  // process, and the next epoch, with memory again, builds it. In a child process, which
  // the limit cannot outlive.
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        World w;
        // 40k Gaussians (copies of the world's, moved and renamed): a hierarchy of tens of
        // megabytes, beyond what the allocator keeps free from the set-up.
        if (!w.store.begin_next_epoch().ok()) std::_Exit(2);
        const std::vector<Gaussian> base(w.store.gaussians().begin(), w.store.gaussians().end());
        for (int copy = 1; copy < 20; ++copy)
          for (const Gaussian& g : base) {
            if (g.carrier) continue;
            Gaussian c = g;
            c.id = GaussianId{to_underlying(g.id) + std::uint64_t(copy) * 1000000};
            c.position.x += 0.01f * float(copy);
            if (!w.store.insert(c).ok()) std::_Exit(2);
          }
        if (!w.store.commit_epoch().ok()) std::_Exit(2);
        // The estimate would see this limit (memory_headroom() reads it): an explicit
        // allowance far above it stands for a limit it cannot see.
        LodConfig unseen;
        unseen.max_bytes = std::size_t{1} << 40;
        LodEpochHierarchy h(w.store.sh_degree(), unseen);
        // What the process has mapped now: the pools' large blocks fail.
        test::AddressSpaceLimit limit(0);
        if (!limit.set()) std::_Exit(3);
        const Status failed = h.update(w.store, nullptr);
        limit.lift();
        if (failed.ok()) std::_Exit(5);
        if (failed.message().find("not enough memory") == std::string::npos) std::_Exit(6);
        if (failed.message().find("ran out") == std::string::npos) std::_Exit(10);  // caught, not estimated
        if (h.hierarchy() != nullptr) std::_Exit(7);
        if (!w.store.begin_next_epoch().ok() || !w.store.commit_epoch().ok()) std::_Exit(8);
        if (!h.update(w.store, nullptr).ok() || h.hierarchy() == nullptr) std::_Exit(9);
        std::_Exit(0);
      },
      ::testing::ExitedWithCode(0), "");
#endif
}

namespace {

// The two trees from their roots: the same nodes (ids, kinds, children) and the same records.
void expect_same_tree(const LodHierarchy& a, std::uint32_t na, const LodHierarchy& b, std::uint32_t nb) {
  const LodNode& x = a.node(na);
  const LodNode& y = b.node(nb);
  ASSERT_EQ(x.id, y.id);
  ASSERT_EQ(x.leaf, y.leaf);
  ASSERT_EQ(x.child_count, y.child_count) << "node " << to_underlying(x.id);
  ASSERT_TRUE(same_value(a.gaussian(x), b.gaussian(y))) << "node " << to_underlying(x.id);
  const auto ka = a.children(x);
  const auto kb = b.children(y);
  for (std::size_t i = 0; i < ka.size(); ++i) expect_same_tree(a, ka[i], b, kb[i]);
}

// An epoch that moves Gaussians across the opacity threshold both ways.
void flip_opacities(World& w, float threshold, int e) {
  ASSERT_TRUE(w.store.begin_next_epoch().ok());
  const float logit = std::log(threshold / (1.0f - threshold));
  std::vector<Gaussian> changed;
  std::size_t k = 0;
  for (const Gaussian& g : w.store.gaussians()) {
    if (g.carrier || !w.store.contains(g.id) || (k++ + std::size_t(e)) % 37 != 0) continue;
    Gaussian c = g;
    c.opacity_logit = g.opacity_logit < logit ? logit + 0.5f : logit - 0.5f;
    changed.push_back(c);
  }
  for (const Gaussian& c : changed) ASSERT_TRUE(w.store.modify(c).ok());
  ASSERT_TRUE(w.store.commit_epoch().ok());
}

}  // namespace

TEST(HostSessionLod, ABackgroundUpdateAppliesAnEligibilityRuleToTheChangesAloneAsAFullComparisonWould) {
  // SessionHost hands the rule, not a verdict over the whole scene: the hierarchy applies it to
  // the changed Gaussians (the rule looks at each alone here). Compared, epoch by epoch, with a
  // hierarchy given filter_eligible's whole verdict without its rule (so it compares every
  // Gaussian): the same tree, node for node and record for record.
  World w;
  const CodecParams params = lod_params(w);
  EligibilityConfig rule;
  rule.min_opacity = 0.3f;
  auto background = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  auto compared = std::make_shared<LodEpochHierarchy>(params.sh_degree, LodConfig{});
  auto check_epoch = [&] {
    for (int k = 0;; ++k) {
      ASSERT_LT(k, 4) << "the background update never became ready";
      auto p = background->update_in_background(w.store, &rule);
      ASSERT_TRUE(p.ok()) << p.message();
      if (*p == LodEpochHierarchy::Progress::Ready) break;
      background->wait_idle();
    }
    auto verdict = filter_eligible(w.store, rule);
    ASSERT_TRUE(verdict.ok());
    ASSERT_GT(verdict->counts.removed_opacity, 0u) << "the rule must leave Gaussians out";
    verdict->rule.reset();  // unknown: every Gaussian is compared
    ASSERT_TRUE(compared->update(w.store, &*verdict).ok());
    const LodHierarchy* a = background->hierarchy();
    const LodHierarchy* b = compared->hierarchy();
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(a->leaf_count(), verdict->indices.size());
    ASSERT_EQ(a->leaf_count(), b->leaf_count());
    expect_same_tree(*a, a->root(), *b, b->root());
  };
  check_epoch();
  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  ASSERT_FALSE(objects.empty());
  for (int e = 0; e < 6; ++e) {
    if (e % 2 == 0)
      churn_epoch(w, objects[std::size_t(e) % objects.size()], e);
    else
      flip_opacities(w, rule.min_opacity, e);
    check_epoch();
    if (HasFatalFailure()) return;
  }
  EXPECT_EQ(background->change_log_updates(), 6u) << "every epoch after the first through the change log";
  EXPECT_EQ(compared->change_log_updates(), 0u);
}

TEST(HostSessionLod, SessionsSharingAnEligibleSetFilterOncePerEpochAndSendWhatTheirOwnFilterGives) {
  World w;
  const CodecParams params = lod_params(w);
  EligibilityConfig rule;
  rule.min_opacity = 0.3f;
  EligibilityConfig stricter = rule;
  stricter.max_scale = 0.05f;
  auto shared = std::make_shared<SharedEligibleSet>(rule);
  auto config = [&](const EligibilityConfig& r, bool share) {
    HostSessionConfig c = lod_config(true);
    c.eligibility = r;
    if (share) c.shared_eligible = shared;
    return c;
  };
  Pair a = connect(w, params, config(rule, true), 250);
  Pair b = connect(w, params, config(rule, true), 250);
  Pair own = connect(w, params, config(rule, false), 250);
  Pair unfiltered = connect(w, params, lod_config(true), 250);
  // Another rule with the same shared set: that set is not this session's verdict.
  Pair other = connect(w, params, config(stricter, true), 250);
  Pair other_own = connect(w, params, config(stricter, false), 250);
  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  for (int e = 0; e < 4; ++e) {
    if (e > 0) churn_epoch(w, objects[std::size_t(e) % objects.size()], e);
    const double t = double(e);
    const Step sa = step(a, w, params, t);
    EXPECT_EQ(sa.payloads, step(b, w, params, t).payloads) << "epoch step " << e;
    EXPECT_EQ(sa.payloads, step(own, w, params, t).payloads) << "epoch step " << e;
    const Step so = step(other, w, params, t);
    EXPECT_EQ(so.payloads, step(other_own, w, params, t).payloads) << "epoch step " << e;
    const Step su = step(unfiltered, w, params, t);
    if (e == 0) {
      EXPECT_NE(sa.payloads, su.payloads) << "the rule must change what is sent, or this shows nothing";
      EXPECT_NE(sa.payloads, so.payloads) << "the two rules must differ in what they send";
    }
    EXPECT_FALSE(sa.payloads.empty());
    EXPECT_EQ(shared->filters(), std::uint64_t(e + 1)) << "one filter per epoch for both sessions";
  }
}

// update_in_background(read_on_worker): the worker copies the scene (a build) or the changed
// Gaussians (the change log) itself, and says when it no longer reads the scene. The trees must
// be what the caller's copy gives, node for node, through a build, churn and a rule's changes.
TEST(HostSessionLod, AWorkerThatReadsTheSceneItselfBuildsWhatACallersCopyBuilds) {
  World w;
  const CodecParams params = lod_params(w);
  LodEpochHierarchy copied(params.sh_degree, LodConfig{});
  LodEpochHierarchy read(params.sh_degree, LodConfig{});
  EligibilityConfig rule;
  rule.min_opacity = 0.3f;
  auto settle = [&](LodEpochHierarchy& h, bool on_worker, const EligibilityConfig* r) {
    for (int k = 0; k < 4; ++k) {
      auto p = h.update_in_background(w.store, r, on_worker);
      ASSERT_TRUE(p.ok()) << p.message();
      if (*p == LodEpochHierarchy::Progress::Ready) break;
      h.wait_idle();
      EXPECT_FALSE(h.reading_scene()) << "a finished job still reading the scene";
    }
    ASSERT_EQ(h.progress(w.store), LodEpochHierarchy::Progress::Ready);
  };
  auto expect_same = [&] {
    ASSERT_NE(copied.hierarchy(), nullptr);
    ASSERT_NE(read.hierarchy(), nullptr);
    ASSERT_EQ(copied.hierarchy()->leaf_count(), read.hierarchy()->leaf_count());
    expect_same_tree(*copied.hierarchy(), copied.hierarchy()->root(), *read.hierarchy(), read.hierarchy()->root());
  };
  ASSERT_NO_FATAL_FAILURE(settle(copied, false, nullptr));
  ASSERT_NO_FATAL_FAILURE(settle(read, true, nullptr));
  EXPECT_TRUE(read.last_update()->built);
  ASSERT_NO_FATAL_FAILURE(expect_same());
  std::vector<ObjectId> objects;
  for (const auto& o : w.store.objects()) objects.push_back(o.id);
  ASSERT_FALSE(objects.empty());
  for (int e = 0; e < 4; ++e) {
    churn_epoch(w, objects[std::size_t(e) % objects.size()], e);
    ASSERT_NO_FATAL_FAILURE(settle(copied, false, nullptr));
    ASSERT_NO_FATAL_FAILURE(settle(read, true, nullptr));
    EXPECT_TRUE(read.last_update()->from_change_log);
    ASSERT_NO_FATAL_FAILURE(expect_same());
  }
  // Under a rule: the first epoch compares every Gaussian (a new rule), the next follows the
  // change log and drops the changed Gaussians that fail it.
  for (int e = 0; e < 2; ++e) {
    flip_opacities(w, rule.min_opacity, e);
    ASSERT_NO_FATAL_FAILURE(settle(copied, false, &rule));
    ASSERT_NO_FATAL_FAILURE(settle(read, true, &rule));
    EXPECT_EQ(read.last_update()->from_change_log, e == 1);
    ASSERT_NO_FATAL_FAILURE(expect_same());
  }
  EXPECT_FALSE(read.reading_scene());
}
