// Differ: applying its edits (also through the codec) to the previous client set gives the
// desired set exactly, over random epochs, poses and queries; updates only when the
// quantised record changed; replaces pair leavers and enterers; every batch has its epoch.
#include <algorithm>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "gauss/engine/codec.h"
#include "gauss/engine/differ.h"
#include "gauss/engine/selector.h"
#include "select_test_scene.h"

namespace gauss {
namespace {

// What a client holds: id -> the record it received.
using ClientSet = std::map<std::uint64_t, Gaussian>;

void apply_batch(ClientSet& client, const EditBatch& batch) {
  for (const Edit& e : batch.edits) {
    const std::uint64_t id = to_underlying(e.id);
    switch (e.kind) {
      case EditKind::Insert:
        ASSERT_EQ(client.count(id), 0u) << "insert of resident id " << id;
        client[id] = e.value;
        break;
      case EditKind::Remove:
        ASSERT_EQ(client.erase(id), 1u) << "remove of absent id " << id;
        break;
      case EditKind::Update:
        ASSERT_EQ(client.count(id), 1u) << "update of absent id " << id;
        client[id] = e.value;
        break;
      case EditKind::Replace:
        ASSERT_EQ(client.erase(to_underlying(e.leaving)), 1u) << "replace of absent id";
        ASSERT_EQ(client.count(id), 0u);
        client[id] = e.value;
        break;
    }
  }
}

// The scene's Gaussians [from, to) as a selection.
Selection scene_range(const SceneStore& store, std::uint32_t from, std::uint32_t to) {
  Selection s;
  s.scene_size = store.gaussians().size();
  s.epoch = store.epoch();
  for (std::uint32_t i = from; i < to; ++i) {
    s.indices.push_back(i);
    s.ids.push_back(store.gaussians()[i].id);
  }
  return s;
}

bool same_record(const Gaussian& a, const Gaussian& b) {
  return a.position == b.position && a.rotation == b.rotation && a.log_scale == b.log_scale &&
         a.opacity_logit == b.opacity_logit && a.sh_dc == b.sh_dc && a.sh_rest == b.sh_rest && a.object == b.object &&
         a.support == b.support;
}

TEST(DifferProperty, EditsReproduceTheDesiredSetExactly) {
  SceneStore store;
  test::fill_test_scene(store, 8000, 31);
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  std::mt19937_64 rng(32);
  Selector selector;
  Differ differ(params);
  ClientSet client;  // receives decoded wire batches
  const SemanticQuery queries[] = {SemanticQuery::for_class("chair"), SemanticQuery::for_instance(ObjectId{2})};
  std::size_t total_updates = 0;
  std::size_t total_replaces = 0;
  for (int step = 0; step < 40; ++step) {
    if (step % 3 == 1) test::evolve_test_scene(store, rng, 0.03);
    SelectionRequest req;
    req.budget = 500 + rng() % 3000;
    req.client_capacity = 4000;
    if (rng() % 2) {
      req.query = queries[rng() % 2];
      req.rho = static_cast<double>(rng() % 101) / 100.0;
    }
    auto sel = selector.select(store, test::random_test_pose(rng), req);
    ASSERT_TRUE(sel.ok()) << sel.message();
    auto batch = differ.diff(*sel, store);
    ASSERT_TRUE(batch.ok()) << batch.message();
    EXPECT_EQ(batch->epoch, store.epoch());
    total_updates += differ.last_stats().updates;
    total_replaces += differ.last_stats().replaces;
    CodecStats cs;
    auto decoded = decode_edit_batch(encode_edit_batch(*batch, params, &cs), params);
    ASSERT_TRUE(decoded.ok()) << decoded.message();
    EXPECT_EQ(decoded->edits.size(), batch->edits.size());
    apply_batch(client, *decoded);
    ASSERT_FALSE(HasFatalFailure());
    // Same ids, and each record is what quantising the current scene value gives.
    ASSERT_EQ(client.size(), sel->ids.size());
    std::size_t k = 0;
    for (const auto& [id, value] : client) {
      ASSERT_EQ(id, to_underlying(sel->ids[k]));
      const Gaussian expect = quantize_roundtrip(store.gaussians()[sel->indices[k]], params);
      EXPECT_TRUE(same_record(value, expect)) << "id " << id << " at step " << step;
      ++k;
    }
    EXPECT_EQ(differ.sent_ids(), sel->ids);
  }
  EXPECT_GT(total_updates, 0u);   // the evolving epochs changed resident records
  EXPECT_GT(total_replaces, 0u);  // pose changes swapped Gaussians
}

TEST(DifferProperty, UpdatesOnlyWhenTheQuantisedRecordChanges) {
  SceneStore store;
  test::fill_test_scene(store, 2000, 41);
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  Selector selector;
  Differ differ(params);
  SelectionRequest req;
  req.budget = 2000;
  req.client_capacity = 2000;
  auto sel = selector.select(store, ClientPose{}, req);
  ASSERT_TRUE(sel.ok());
  auto first = differ.diff(*sel, store);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(differ.last_stats().inserts, sel->ids.size());
  // Same selection again: nothing to send.
  auto again = differ.diff(*sel, store);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->edits.empty());
  // Modify two resident Gaussians: one far below a quantisation step, one by a lot.
  const Gaussian a = store.gaussians()[sel->indices[0]];
  const Gaussian b = store.gaussians()[sel->indices[1]];
  ASSERT_TRUE(store.begin_next_epoch().ok());
  Gaussian a2 = a;
  a2.position.x = std::nextafter(a.position.x, 1e9f);
  ASSERT_TRUE(same_value(quantize_roundtrip(a2, params), quantize_roundtrip(a, params)));
  Gaussian b2 = b;
  b2.sh_dc += glm::vec3(0.5f);
  ASSERT_TRUE(store.modify(a2).ok());
  ASSERT_TRUE(store.modify(b2).ok());
  ASSERT_TRUE(store.commit_epoch().ok());
  sel = selector.select(store, ClientPose{}, req);
  ASSERT_TRUE(sel.ok());
  auto upd = differ.diff(*sel, store);
  ASSERT_TRUE(upd.ok());
  ASSERT_EQ(upd->edits.size(), 1u);
  EXPECT_EQ(upd->edits[0].kind, EditKind::Update);
  EXPECT_EQ(upd->edits[0].id, b.id);
  EXPECT_EQ(upd->epoch, store.epoch());
  EXPECT_EQ(differ.last_stats().rehashed, 2u);  // only the logged modifications were checked
}

TEST(DifferProperty, PairsLeaversAndEnterersIntoReplaces) {
  SceneStore store;
  test::fill_test_scene(store, 100, 51);
  Differ differ(fit_codec_params(store.gaussians(), 0));
  auto make = [&](std::uint32_t from, std::uint32_t to) { return scene_range(store, from, to); };
  ASSERT_TRUE(differ.diff(make(0, 50), store).ok());
  auto b = differ.diff(make(10, 70), store);  // 10 leave, 20 enter
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(differ.last_stats().replaces, 10u);
  EXPECT_EQ(differ.last_stats().inserts, 10u);
  EXPECT_EQ(differ.last_stats().removes, 0u);
  auto c = differ.diff(make(30, 40), store);  // 50 leave, 0 enter
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(differ.last_stats().removes, 50u);
  EXPECT_EQ(differ.sent_count(), 10u);
  // A selection that does not match the scene is refused, and the sent state is kept.
  Selection wrong = make(0, 5);
  wrong.ids[2] = GaussianId{999999};
  EXPECT_FALSE(differ.diff(wrong, store).ok());
  Selection dup = make(0, 5);
  dup.ids[1] = dup.ids[0];
  dup.indices[1] = dup.indices[0];
  EXPECT_FALSE(differ.diff(dup, store).ok());
  EXPECT_EQ(differ.sent_count(), 10u);
}

TEST(DifferProperty, KeepsEachSentRecordAsSentThroughLaterEpochsAndFailedDiffs) {
  SceneStore store;
  test::fill_test_scene(store, 200, 61);
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  Differ differ(params);
  auto make = [&](std::uint32_t from, std::uint32_t to) { return scene_range(store, from, to); };
  ClientSet client;
  auto first = differ.diff(make(0, 100), store);
  ASSERT_TRUE(first.ok());
  apply_batch(client, *decode_edit_batch(encode_edit_batch(*first, params), params));
  auto held_as_sent = [&] {
    ASSERT_EQ(differ.sent_count(), client.size());
    std::size_t visited = 0;
    differ.for_each_sent([&](const Gaussian& g) {
      ++visited;
      ASSERT_EQ(client.count(to_underlying(g.id)), 1u);
      EXPECT_TRUE(same_record(g, client[to_underlying(g.id)])) << "id " << to_underlying(g.id);
      EXPECT_EQ(g.id, client[to_underlying(g.id)].id);
    });
    EXPECT_EQ(visited, client.size());
  };
  held_as_sent();
  // The scene moves on (sent records recoloured) with no diff since: the record stays what
  // was sent.
  const Gaussian a = store.gaussians()[30];
  ASSERT_TRUE(store.begin_next_epoch().ok());
  Gaussian a2 = a;
  a2.sh_dc += glm::vec3(0.5f);
  ASSERT_TRUE(store.modify(a2).ok());
  ASSERT_TRUE(store.commit_epoch().ok());
  ASSERT_FALSE(same_value(quantize_roundtrip(store.gaussians()[30], params), quantize_roundtrip(a, params)));
  held_as_sent();
  EXPECT_TRUE(same_record(*differ.sent_record(a.id), quantize_roundtrip(a, params)));
  EXPECT_FALSE(differ.sent_record(store.gaussians()[150].id).has_value()) << "never sent";
  // A diff that fails after taking slots for the update and for some enterers (the last
  // enterer does not match the scene) changes nothing: the record, the update still to send.
  Selection wrong = make(10, 160);
  wrong.ids.back() = GaussianId{to_underlying(wrong.ids.back()) + 100000};
  EXPECT_FALSE(differ.diff(wrong, store).ok());
  held_as_sent();
  auto next = differ.diff(make(10, 160), store);
  ASSERT_TRUE(next.ok());
  EXPECT_EQ(differ.last_stats().updates, 1u);
  apply_batch(client, *decode_edit_batch(encode_edit_batch(*next, params), params));
  held_as_sent();
  // Slots freed by leavers and updates are reused, records stay exact through many diffs.
  for (std::uint32_t k = 0; k < 20; ++k) {
    auto b = differ.diff(make(5 * k, 5 * k + 60 + k % 7), store);
    ASSERT_TRUE(b.ok());
    apply_batch(client, *decode_edit_batch(encode_edit_batch(*b, params), params));
  }
  held_as_sent();
  differ.reset();
  EXPECT_EQ(differ.sent_count(), 0u);
  EXPECT_FALSE(differ.sent_record(a.id).has_value());
}

TEST(DifferProperty, LastSentRecordsAreTheValueEditsAsSentAndTheEncoderCopiesThem) {
  SceneStore store;
  test::fill_test_scene(store, 200, 71);
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  const std::size_t stride = sent_record_bytes(params.sh_degree);
  const std::size_t rec = record_bytes(params.sh_degree);
  Differ differ(params);
  auto make = [&](std::uint32_t from, std::uint32_t to) { return scene_range(store, from, to); };
  // Each value edit's sent record, in batch order, as write_sent_record gives it.
  auto expect_records_of = [&](const EditBatch& b) {
    std::vector<std::uint8_t> want;
    for (const Edit& e : b.edits) {
      if (e.kind == EditKind::Remove) continue;
      want.resize(want.size() + stride);
      write_sent_record(e.value, params, want.data() + want.size() - stride);
    }
    const auto got = differ.last_sent_records();
    ASSERT_EQ(got.size(), want.size());
    EXPECT_TRUE(std::equal(got.begin(), got.end(), want.begin()));
  };
  auto first = differ.diff(make(0, 100), store);
  ASSERT_TRUE(first.ok());
  expect_records_of(*first);
  // A batch of every kind: 10 leave and 60 enter (10 replaces, 50 inserts), one update.
  ASSERT_TRUE(store.begin_next_epoch().ok());
  Gaussian moved = store.gaussians()[40];
  moved.sh_dc += glm::vec3(0.5f);
  ASSERT_TRUE(store.modify(moved).ok());
  ASSERT_TRUE(store.commit_epoch().ok());
  auto b = differ.diff(make(10, 160), store);
  ASSERT_TRUE(b.ok());
  ASSERT_EQ(differ.last_stats().replaces, 10u);
  ASSERT_EQ(differ.last_stats().inserts, 50u);
  ASSERT_EQ(differ.last_stats().updates, 1u);
  expect_records_of(*b);

  // The encoder copies them: the same payload as quantising again.
  const std::vector<std::uint8_t> plain = encode_edit_batch_raw(*b, params);
  const std::vector<std::uint8_t> sent(differ.last_sent_records().begin(), differ.last_sent_records().end());
  EXPECT_EQ(encode_edit_batch_raw(*b, params, nullptr, sent), plain);
  EXPECT_EQ(decode_edit_batch(encode_edit_batch(*b, params, nullptr, sent), params)->edits.size(), b->edits.size());
  // Copied, not quantised: a changed record byte and support code reach the decoded batch.
  std::vector<std::uint8_t> altered = sent;
  const std::size_t v = 10;  // the update: after the 10 replaces
  altered[v * stride + 0] ^= 0x01;        // lowest bit of the position's x code
  altered[v * stride + rec + 4] ^= 0x01;  // the support code
  auto decoded = decode_edit_batch_raw(encode_edit_batch_raw(*b, params, nullptr, altered), params);
  auto decoded_plain = decode_edit_batch_raw(plain, params);
  ASSERT_TRUE(decoded.ok());
  ASSERT_TRUE(decoded_plain.ok());
  ASSERT_EQ(decoded->edits.size(), decoded_plain->edits.size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < decoded->edits.size(); ++i) {
    if (same_record(decoded->edits[i].value, decoded_plain->edits[i].value)) continue;
    ++differing;
    EXPECT_EQ(decoded->edits[i].kind, EditKind::Update);
    EXPECT_EQ(decoded->edits[i].id, moved.id);
    EXPECT_NE(decoded->edits[i].value.position.x, decoded_plain->edits[i].value.position.x);
    EXPECT_NE(decoded->edits[i].value.support, decoded_plain->edits[i].value.support);
  }
  EXPECT_EQ(differing, 1u);
  // Records of another size, or stats to count, and every record is quantised.
  std::vector<std::uint8_t> short_by_one(altered.begin(), altered.end() - 1);
  EXPECT_EQ(encode_edit_batch_raw(*b, params, nullptr, short_by_one), plain);
  CodecStats stats;
  EXPECT_EQ(encode_edit_batch_raw(*b, params, &stats, altered), plain);
  EXPECT_EQ(stats.gaussians, 61u);

  // None after a failed diff, or after a reset.
  Selection wrong = make(20, 170);
  wrong.ids.back() = GaussianId{to_underlying(wrong.ids.back()) + 100000};
  EXPECT_FALSE(differ.diff(wrong, store).ok());
  EXPECT_TRUE(differ.last_sent_records().empty());
  ASSERT_TRUE(differ.diff(make(20, 170), store).ok());
  EXPECT_FALSE(differ.last_sent_records().empty());
  differ.reset();
  EXPECT_TRUE(differ.last_sent_records().empty());
}

// diff_headers is diff without each value edit's Gaussian: the same edits in the same order,
// the same sent records and stats, and from them encode_edit_headers writes the payload
// encode_edit_batch writes for the full batch (object ids and support codes included, read
// from the sent records), over epochs that insert, modify and remove.
TEST(DifferProperty, EditHeadersAreTheDiffWithoutItsValuesAndEncodeTheSamePayload) {
  SceneStore store;
  test::fill_test_scene(store, 400, 73);
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  std::set<std::int32_t> objects;
  for (const Gaussian& g : store.gaussians()) objects.insert(to_underlying(g.object));
  ASSERT_GE(objects.size(), 3u);  // the objects column carries something
  Differ full(params), headers(params);
  std::mt19937 rng(5);
  for (int step = 0; step < 12; ++step) {
    if (step % 3 == 2) {  // a new epoch: a few records change
      ASSERT_TRUE(store.begin_next_epoch().ok());
      for (int i = 0; i < 20; ++i) {
        Gaussian g = store.gaussians()[rng() % store.gaussians().size()];
        g.sh_dc += glm::vec3(0.3f);
        g.support += 7;
        ASSERT_TRUE(store.modify(g).ok());
      }
      ASSERT_TRUE(store.commit_epoch().ok());
    }
    const std::uint32_t n = std::uint32_t(store.gaussians().size());
    const std::uint32_t from = rng() % (n / 2), to = from + 1 + rng() % (n - from - 1);
    const Selection desired = scene_range(store, from, to);
    auto fb = full.diff(desired, store);
    auto hb = headers.diff_headers(desired, store);
    ASSERT_TRUE(fb.ok() && hb.ok());
    EXPECT_EQ(hb->epoch, fb->epoch);
    ASSERT_EQ(hb->edits.size(), fb->edits.size());
    for (std::size_t i = 0; i < fb->edits.size(); ++i) {
      EXPECT_EQ(hb->edits[i].kind, fb->edits[i].kind);
      EXPECT_EQ(hb->edits[i].id, fb->edits[i].id);
      EXPECT_EQ(hb->edits[i].leaving, fb->edits[i].leaving);
    }
    const auto fr = full.last_sent_records();
    const auto hr = headers.last_sent_records();
    ASSERT_EQ(fr.size(), hr.size());
    EXPECT_TRUE(std::equal(fr.begin(), fr.end(), hr.begin()));
    EXPECT_EQ(headers.last_stats().edits(), full.last_stats().edits());
    EXPECT_EQ(headers.last_stats().replaces, full.last_stats().replaces);
    EXPECT_EQ(headers.last_stats().updates, full.last_stats().updates);
    auto payload = encode_edit_headers(*hb, params, hr);
    ASSERT_TRUE(payload.ok()) << payload.message();
    EXPECT_EQ(*payload, encode_edit_batch(*fb, params)) << "step " << step;
  }
  // The records must be exactly those of the value edits.
  Selection desired = scene_range(store, 0, 50);
  auto hb = headers.diff_headers(desired, store);
  ASSERT_TRUE(hb.ok());
  std::vector<std::uint8_t> records(headers.last_sent_records().begin(), headers.last_sent_records().end());
  if (!records.empty()) {
    records.pop_back();
    const auto short_one = encode_edit_headers(*hb, params, records);
    ASSERT_FALSE(short_one.ok());
    EXPECT_NE(short_one.message().find("sent records"), std::string::npos) << short_one.message();
  }
  EXPECT_TRUE(encode_edit_headers(EditHeaderBatch{}, params, {}).ok());
}

}  // namespace
}  // namespace gauss
