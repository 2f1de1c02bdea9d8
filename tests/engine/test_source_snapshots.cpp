// Scene sources: snapshot folder replay (trainer layout ordered by iteration number, flat
// folders ordered by number), corrupt/missing/NaN snapshots logged and skipped with the last
// good epoch kept, identity tracking for id-less snapshots, given ids, labels, objects JSON,
// meshes, one PLY as one epoch, the synthetic source; a snapshot too large for the process
// skipped the same way.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "gauss/engine/labels_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/scene_source.h"
#include "address_space_limit.h"
#include "nan_ply.h"
#include "test_data.h"

namespace gauss {
namespace {

namespace fs = std::filesystem;

// n Gaussians on a grid; `shift` moves them all (a different snapshot of "the same" scene).
GaussianCloud grid_cloud(std::size_t n, float shift = 0.0f) {
  GaussianCloud c;
  c.sh_degree = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Gaussian g;
    g.position = glm::vec3(float(i % 10) * 0.1f + shift, float(i / 10 % 10) * 0.1f, float(i / 100) * 0.1f);
    g.log_scale = glm::vec3(std::log(0.03f));
    g.opacity_logit = 1.0f;
    g.sh_dc = glm::vec3(0.1f * float(i % 7), 0.2f, -0.3f);
    c.gaussians.push_back(g);
  }
  return c;
}

void write(const fs::path& p, const GaussianCloud& c, PlyGaussianWriteOptions o = {}) {
  fs::create_directories(p.parent_path());
  ASSERT_TRUE(write_gaussian_ply(p, c, o).ok()) << p;
}

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// `cloud` as an ASCII PLY whose vertices v with nan_at(v) have x = nan (a trainer's NaN).
template <class NanAt>
void write_with_nans(const fs::path& p, const GaussianCloud& cloud, NanAt nan_at) {
  const std::string text = test::ascii_ply_with_nans(cloud, nan_at);
  ASSERT_FALSE(text.empty());
  write_text(p, text);
}

struct Collect {
  std::vector<std::string> lines;
  SourceLog log() {
    return [this](const std::string& l) { lines.push_back(l); };
  }
};

// Replays every epoch `src` has into `store`, recording the store size after each.
void replay_all(SceneSource& src, SceneStore& store, std::vector<std::size_t>& sizes) {
  for (;;) {
    auto r = src.next_epoch(store);
    ASSERT_TRUE(r.ok()) << r.message();
    if (!*r) break;
    sizes.push_back(store.size());
  }
}

TEST(SourceSnapshots, TrainerLayoutReplaysByIterationNumberWithIdentityTracking) {
  const fs::path root = test::fresh_output_dir("source_snapshots/trainer");
  // Iterations in an order where name sorting would be wrong: 500 < 7000 < 30000.
  GaussianCloud a = grid_cloud(300);
  GaussianCloud b = a;  // + 20 new, then permuted (densification reorders)
  for (std::size_t k = 0; k < 20; ++k) {
    Gaussian g = a.gaussians[k];
    g.position += glm::vec3(5.0f, 0.0f, 0.0f);
    b.gaussians.push_back(g);
  }
  std::reverse(b.gaussians.begin(), b.gaussians.end());
  GaussianCloud c = b;
  c.gaussians.resize(250);  // 70 pruned
  write(root / "point_cloud/iteration_500/point_cloud.ply", a);
  write(root / "point_cloud/iteration_7000/point_cloud.ply", b);
  write(root / "point_cloud/iteration_30000/point_cloud.ply", c);
  fs::create_directories(root / "point_cloud/not_an_iteration");

  Collect log;
  SnapshotOptions settled;
  settled.settle_s = 0.0;  // files just written count as finished (see HalfWrittenSnapshot...)
  auto src = open_snapshot_folder(root, settled, log.log());
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  std::vector<std::size_t> sizes;
  ASSERT_NO_FATAL_FAILURE(replay_all(**src, store, sizes));
  EXPECT_EQ(sizes, (std::vector<std::size_t>{300, 320, 250}));
  EXPECT_TRUE(log.lines.empty()) << log.lines.front();
  // Identity tracking kept every unchanged Gaussian: epoch 2 inserted only the 20 new ones,
  // modified none; epoch 3 only removed.
  const EpochChanges* e2 = store.changes(Epoch{2});
  ASSERT_NE(e2, nullptr);
  EXPECT_EQ(e2->inserted.size(), 20u);
  EXPECT_EQ(e2->modified.size(), 0u);
  EXPECT_EQ(e2->removed.size(), 0u);
  const EpochChanges* e3 = store.changes(Epoch{3});
  ASSERT_NE(e3, nullptr);
  EXPECT_EQ(e3->removed.size(), 70u);
  EXPECT_EQ(e3->inserted.size() + e3->modified.size(), 0u);
}

TEST(SourceSnapshots, BadSnapshotsAreLoggedAndSkippedKeepingTheLastGoodEpoch) {
  const fs::path root = test::fresh_output_dir("source_snapshots/flat");
  write(root / "snap_1.ply", grid_cloud(100));
  write(root / "snap_2.ply", grid_cloud(110));
  write_text(root / "snap_3.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 5\nend_header\nxx");
  // NaN: an ASCII snapshot with one value replaced by nan (its Gaussian is left out, the
  // rest applied, and the log says so).
  write_with_nans(root / "snap_4.ply", grid_cloud(120), [](std::size_t v) { return v == 0; });
  // A trainer that diverged: a third of snap_5's Gaussians are NaN. With snap_4 in the store,
  // it is skipped like a broken one (the store keeps what was good).
  write_with_nans(root / "snap_5.ply", grid_cloud(125), [](std::size_t v) { return v % 3 == 0; });
  write(root / "snap_10.ply", grid_cloud(130));  // 10 after 4: numeric, not name order
  write(root / "snap_1_mesh.ply", {});  // a mesh by its name, never replayed as a snapshot

  Collect log;
  SnapshotOptions settled;
  settled.settle_s = 0.0;  // files just written count as finished (see HalfWrittenSnapshot...)
  auto src = open_snapshot_folder(root, settled, log.log());
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  std::vector<std::size_t> sizes;
  ASSERT_NO_FATAL_FAILURE(replay_all(**src, store, sizes));
  // The third call met snap_3 (corrupt), skipped it and applied snap_4 without its NaN
  // Gaussian; the fourth skipped snap_5 (diverged) and applied snap_10.
  EXPECT_EQ(sizes, (std::vector<std::size_t>{100, 110, 119, 130}));
  ASSERT_GE(log.lines.size(), 2u);
  const auto mentions = [&](const std::string& what) {
    return std::any_of(log.lines.begin(), log.lines.end(),
                       [&](const std::string& l) { return l.find(what) != std::string::npos; });
  };
  EXPECT_TRUE(mentions("snap_3.ply")) << "corrupt file not logged";
  EXPECT_TRUE(mentions("snap_4.ply: left out 1 of 120 Gaussians with a non-finite value (the first: vertex 0, "
                       "property 'x' (line "))
      << "NaN Gaussian not logged";
  EXPECT_TRUE(mentions("skipped snapshot " + (root / "snap_5.ply").string() + ": 42 of its 125 Gaussians hold a NaN or "
                       "Inf (the trainer diverged?), the first: vertex 0, property 'x' (line "))
      << "a diverged snapshot is not skipped";
  EXPECT_EQ((*src)->messages().size(), log.lines.size());

  // A trainer still writing: a later file appears and is picked up by the next call.
  write(root / "snap_11.ply", grid_cloud(140));
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(*r);
  EXPECT_EQ(store.size(), 140u);
}

// prepare_in_background: the same epochs, ids, values and log lines as reading on the
// caller's thread, each snapshot taken up by a later call than the one that started it
// (busy() in between), bad ones skipped the same way, tracking included.
TEST(SourceSnapshots, PreparedInTheBackgroundTheEpochsAreTheSame) {
  const fs::path root = test::fresh_output_dir("source_snapshots/background");
  write(root / "snap_1.ply", grid_cloud(1000));
  write(root / "snap_2.ply", grid_cloud(1000, 0.004f));  // every Gaussian moved: tracked
  write_text(root / "snap_3.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 5\nend_header\nxx");
  write(root / "snap_4.ply", grid_cloud(900, 0.006f));
  write(root / "snap_5.ply", grid_cloud(950, 0.006f));
  SnapshotOptions now, background;
  now.settle_s = background.settle_s = 0.0;
  background.prepare_in_background = true;
  Collect now_log, background_log;
  auto a = open_snapshot_folder(root, now, now_log.log());
  auto b = open_snapshot_folder(root, background, background_log.log());
  ASSERT_TRUE(a.ok() && b.ok());
  SceneStore sa, sb;
  int epochs = 0;
  for (;;) {
    auto ra = (*a)->next_epoch(sa);
    ASSERT_TRUE(ra.ok()) << ra.message();
    bool rb = false, waited = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    for (;;) {
      auto r = (*b)->next_epoch(sb);
      ASSERT_TRUE(r.ok()) << r.message();
      rb = *r;
      if (rb || !(*b)->busy()) break;
      waited = true;
      ASSERT_LT(std::chrono::steady_clock::now(), deadline);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    ASSERT_EQ(*ra, rb) << "epoch " << epochs;
    if (!rb) break;
    EXPECT_TRUE(waited) << "committed by the call that started it";
    ++epochs;
    ASSERT_EQ(sa.epoch(), sb.epoch());
    ASSERT_EQ(sa.size(), sb.size());
    for (const Gaussian& g : sa.gaussians()) {
      const Gaussian* h = sb.find(g.id);
      ASSERT_NE(h, nullptr) << "id " << to_underlying(g.id) << " epoch " << epochs;
      EXPECT_TRUE(same_value(g, *h));
    }
  }
  EXPECT_EQ(epochs, 4);
  EXPECT_EQ(now_log.lines, background_log.lines);
  EXPECT_FALSE((*b)->busy());
}

// A prepared snapshot is committed only to the epoch it was matched against: after any other
// epoch (something else changed the store) the commit is refused and the store is as it was.
TEST(SourceSnapshots, APreparedSnapshotIsRefusedByAStoreThatMovedOn) {
  SceneStore store;
  ASSERT_TRUE(apply_snapshot(store, grid_cloud(100), false).ok());
  auto prepared = prepare_snapshot(store, grid_cloud(100, 0.004f), false);
  ASSERT_TRUE(prepared.ok()) << prepared.message();
  EXPECT_EQ(prepared->against, store.epoch());
  ASSERT_TRUE(store.begin_next_epoch().ok());
  Gaussian extra;
  extra.id = store.allocate_id();
  extra.position = glm::vec3(5.0f);
  ASSERT_TRUE(store.insert(extra).ok());
  ASSERT_TRUE(store.commit_epoch().ok());
  const Epoch at = store.epoch();
  auto r = commit_snapshot(store, std::move(*prepared));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("prepared against epoch 1, the store is at epoch 2"), std::string::npos) << r.message();
  EXPECT_EQ(store.epoch(), at);
  EXPECT_EQ(store.size(), 101u);
  // Prepared again, it goes in: the moved grid keeps its ids, the extra one leaves.
  auto again = prepare_snapshot(store, grid_cloud(100, 0.004f), false);
  ASSERT_TRUE(again.ok());
  auto applied = commit_snapshot(store, std::move(*again));
  ASSERT_TRUE(applied.ok()) << applied.message();
  EXPECT_EQ(applied->modified, 100u);
  EXPECT_EQ(applied->removed, 1u);
  EXPECT_EQ(store.size(), 100u);
}

// A trainer's scene that outgrows the process (its densification can multiply it): the
// snapshot is skipped with the figures, the store keeps the last one that fitted, and the
// next snapshot that fits is taken. Under an address-space limit in a child, which the
// limit cannot outlive; the machine's own limits are met the same way (memory_headroom()).
TEST(SourceSnapshots, ASnapshotTooLargeForTheProcessIsSkippedKeepingTheLastGoodEpoch) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan reserves more address space than the limit this test sets";
#else
  const fs::path root = test::fresh_output_dir("source_snapshots/memory");
  write(root / "snap_1.ply", grid_cloud(100));
  write(root / "snap_2.ply", grid_cloud(200000));  // about 53 MB once read, 65 MB more in the store
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        Collect log;
        SnapshotOptions settled;
        settled.settle_s = 0.0;
        auto src = open_snapshot_folder(root, settled, log.log());
        SceneStore store;
        if (!src.ok() || !(*src)->next_epoch(store).ok() || store.size() != 100) std::_Exit(2);
        test::AddressSpaceLimit limit(std::size_t{80} << 20);
        if (!limit.set()) std::_Exit(3);
        auto r = (*src)->next_epoch(store);
        limit.lift();
        // Skipped, not an error: the source has produced before, and the store is untouched.
        if (!r.ok() || *r) std::_Exit(5);
        if (store.size() != 100 || store.epoch() != Epoch{1} || store.in_epoch()) std::_Exit(6);
        const bool said = std::any_of(log.lines.begin(), log.lines.end(), [](const std::string& l) {
          return l.find("skipped snapshot") != std::string::npos && l.find("snap_2.ply") != std::string::npos &&
                 l.find("not enough memory") != std::string::npos && l.find("keeps epoch 1") != std::string::npos;
        });
        if (!said) {
          for (const auto& l : log.lines) std::fprintf(stderr, "%s\n", l.c_str());
          std::_Exit(7);
        }
        // With memory back, the next snapshot is taken.
        write(root / "snap_3.ply", grid_cloud(300));
        auto next = (*src)->next_epoch(store);
        std::_Exit(next.ok() && *next && store.size() == 300 ? 0 : 8);
      },
      ::testing::ExitedWithCode(0), "");
#endif
}

// The same refusal where apply_snapshot meets it: the snapshot is read and compared, and the
// store's room is asked for before its epoch opens, naming the limit that binds.
TEST(SourceSnapshots, ApplyAsksForTheStoresRoomBeforeTheEpochOpens) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan reserves more address space than the limit this test sets";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        SceneStore store;
        if (!apply_snapshot(store, grid_cloud(50), false, {}, {}, nullptr).ok()) std::_Exit(2);
        GaussianCloud big = grid_cloud(200000);
        GaussianCloud given = big;  // the call takes its cloud by value: copied before the limit
        // Room for the comparison's id sets (a few MB), not for the store's 65 MB.
        test::AddressSpaceLimit limit(std::size_t{40} << 20);
        if (!limit.set()) std::_Exit(3);
        auto r = apply_snapshot(store, std::move(given), false, {}, {}, nullptr);
        limit.lift();
        if (r.ok()) std::_Exit(5);
        std::fprintf(stderr, "%s\n", r.message().c_str());
        if (r.message().find("not enough memory: a scene of 200000 Gaussians needs about") == std::string::npos ||
            r.message().find("the address-space limit (ulimit -v)") == std::string::npos)
          std::_Exit(6);
        if (store.size() != 50 || store.epoch() != Epoch{1} || store.in_epoch()) std::_Exit(7);
        auto again = apply_snapshot(store, std::move(big), false, {}, {}, nullptr);
        std::_Exit(again.ok() && store.size() == 200000 ? 0 : 8);
      },
      ::testing::ExitedWithCode(0), "");
#endif
}

TEST(SourceSnapshots, CorruptLastSnapshotKeepsTheStoreUntouched) {
  const fs::path root = test::fresh_output_dir("source_snapshots/keep");
  write(root / "0001.ply", grid_cloud(100));
  SnapshotOptions settled;
  settled.settle_s = 0.0;
  auto src = open_snapshot_folder(root, settled, [](const std::string&) {});
  ASSERT_TRUE(src.ok());
  SceneStore store;
  ASSERT_TRUE((*src)->next_epoch(store).ok());
  const std::vector<Gaussian> before(store.gaussians().begin(), store.gaussians().end());
  write_text(root / "0002.ply", "garbage");
  // A missing file: an iteration folder would hold it; a flat folder lists only present files,
  // so simulate a vanished snapshot with a dangling symlink.
  fs::create_symlink(root / "does_not_exist.ply", root / "0003.ply");
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_FALSE(*r);
  EXPECT_EQ(store.epoch(), Epoch{1});
  ASSERT_EQ(store.size(), before.size());
  for (std::size_t i = 0; i < before.size(); ++i) EXPECT_EQ(store.gaussians()[i].position, before[i].position);
  EXPECT_EQ((*src)->messages().size(), 2u);
}

// A trainer writes its next snapshot while the host lists the folder: a file that fails
// to load but was written within settle_s is waited for (the store keeps its epoch, one
// message), and read once complete; one still bad after settling is skipped.
TEST(SourceSnapshots, HalfWrittenSnapshotIsRetriedNotSkipped) {
  const fs::path root = test::fresh_output_dir("source_snapshots/half");
  write(root / "snap_1.ply", grid_cloud(100));
  Collect log;
  SnapshotOptions o;
  o.settle_s = 3600.0;  // everything written by this test is "recent"
  auto src = open_snapshot_folder(root, o, log.log());
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  ASSERT_TRUE(*(*src)->next_epoch(store));
  auto full = encode_gaussian_ply(grid_cloud(120));
  ASSERT_TRUE(full.ok());
  const std::string bytes(full->begin(), full->end());
  write_text(root / "snap_2.ply", bytes.substr(0, bytes.size() / 2));
  for (int call = 0; call < 3; ++call) {
    auto r = (*src)->next_epoch(store);
    ASSERT_TRUE(r.ok()) << r.message();
    EXPECT_FALSE(*r) << "a half-written snapshot is not an epoch";
  }
  EXPECT_EQ(store.epoch(), Epoch{1});
  EXPECT_EQ(store.size(), 100u);
  ASSERT_EQ(log.lines.size(), 1u) << "reported once while waiting";
  EXPECT_NE(log.lines[0].find("waiting for"), std::string::npos) << log.lines[0];
  write_text(root / "snap_2.ply", bytes);  // the trainer finished
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_TRUE(*r);
  EXPECT_EQ(store.size(), 120u);
  // Really corrupt: still bad once it is older than settle_s, so it is skipped.
  write_text(root / "snap_3.ply", bytes.substr(0, 100));
  write(root / "snap_4.ply", grid_cloud(90));
  ASSERT_FALSE(*(*src)->next_epoch(store)) << "snap_3 is recent: waited for, snap_4 not reached";
  fs::last_write_time(root / "snap_3.ply", fs::file_time_type::clock::now() - std::chrono::hours(2));
  r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_TRUE(*r);
  EXPECT_EQ(store.size(), 90u);
  EXPECT_NE(log.lines.back().find("skipped snapshot"), std::string::npos) << log.lines.back();
}

TEST(SourceSnapshots, MissingIterationFileIsSkipped) {
  const fs::path root = test::fresh_output_dir("source_snapshots/missing");
  write(root / "point_cloud/iteration_100/point_cloud.ply", grid_cloud(50));
  fs::create_directories(root / "point_cloud/iteration_200");  // no point_cloud.ply
  // Made an hour ago: not a folder a trainer is about to write into (next test).
  fs::last_write_time(root / "point_cloud/iteration_200", fs::file_time_type::clock::now() - std::chrono::hours(1));
  write(root / "point_cloud/iteration_300/point_cloud.ply", grid_cloud(60));
  Collect log;
  auto src = open_snapshot_folder(root, {}, log.log());
  ASSERT_TRUE(src.ok());
  SceneStore store;
  ASSERT_TRUE(*(*src)->next_epoch(store));
  ASSERT_TRUE(*(*src)->next_epoch(store));
  EXPECT_EQ(store.size(), 60u);
  EXPECT_EQ(store.epoch(), Epoch{2});
  ASSERT_EQ(log.lines.size(), 1u);
  EXPECT_NE(log.lines[0].find("iteration_200"), std::string::npos) << log.lines[0];
}

// A trainer makes an iteration's folder, then writes its file into it: a folder made within
// the settle time whose file is not there yet is waited for, not skipped for good (which
// lost that iteration, the final one too, when a poll fell between the two).
TEST(SourceSnapshots, AFreshIterationFolderIsWaitedForUntilItsFileComes) {
  const fs::path root = test::fresh_output_dir("source_snapshots/fresh_folder");
  write(root / "point_cloud/iteration_100/point_cloud.ply", grid_cloud(50));
  Collect log;
  SnapshotOptions o;
  o.settle_s = 3600.0;  // anything written this hour may still be in progress
  auto src = open_snapshot_folder(root, o, log.log());
  ASSERT_TRUE(src.ok());
  SceneStore store;
  ASSERT_TRUE(*(*src)->next_epoch(store));
  fs::create_directories(root / "point_cloud/iteration_200");
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_FALSE(*r);
  ASSERT_EQ(log.lines.size(), 1u);
  EXPECT_NE(log.lines[0].find("waiting for"), std::string::npos) << log.lines[0];
  EXPECT_NE(log.lines[0].find("iteration_200"), std::string::npos) << log.lines[0];
  write(root / "point_cloud/iteration_200/point_cloud.ply", grid_cloud(70));
  r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_TRUE(*r);
  EXPECT_EQ(store.size(), 70u);
  EXPECT_EQ(log.lines.size(), 1u);  // said once
}

TEST(SourceSnapshots, GivenIdsObjectsJsonLabelsAndMesh) {
  const fs::path root = test::fresh_output_dir("source_snapshots/ids");
  GaussianCloud a = grid_cloud(10);
  for (std::size_t i = 0; i < 10; ++i) {
    a.gaussians[i].id = GaussianId{100 + i};
    a.gaussians[i].object = ObjectId{i < 4 ? 1 : 2};
  }
  PlyGaussianWriteOptions o;
  o.write_gaussian_id = true;
  o.write_object_id = true;
  write(root / "s1.ply", a, o);
  GaussianCloud b = a;
  b.gaussians.erase(b.gaussians.begin());  // id 100 removed
  b.gaussians[0].opacity_logit = 3.0f;     // id 101 modified
  write(root / "s2.ply", b, o);
  GaussianCloud c = a;  // id 100 comes back: ids are never reused -> skipped
  write(root / "s3.ply", c, o);
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
  mesh.colors.assign(3, {10, 20, 30});
  mesh.indices = {0, 2, 1};
  ASSERT_TRUE(write_mesh_ply(root / "s1_mesh.ply", mesh).ok());
  write_text(root / "objects.json", R"({"objects": [{"id": 1, "label": "chair", "quality": 0.5}, {"id": 2, "label": "table"}]})");

  Collect log;
  auto src = open_snapshot_folder(root, {}, log.log());
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  ASSERT_TRUE(*(*src)->next_epoch(store));
  EXPECT_NE(store.find(GaussianId{100}), nullptr);
  ASSERT_EQ(store.objects().size(), 2u);
  EXPECT_EQ(store.find_object(ObjectId{1})->label, "chair");
  EXPECT_EQ(store.find_object(ObjectId{1})->members.size(), 4u);
  EXPECT_FLOAT_EQ(store.find_object(ObjectId{1})->quality, 0.5f);
  EXPECT_EQ(store.find_object(ObjectId{2})->label, "table");
  ASSERT_EQ(store.surface_chunks().size(), 1u);
  EXPECT_EQ(store.surface_chunks()[0].mesh.indices.size(), 3u);
  EXPECT_EQ(store.surface_chunks()[0].epoch, Epoch{1});

  ASSERT_TRUE(*(*src)->next_epoch(store));
  const EpochChanges* e2 = store.changes(Epoch{2});
  ASSERT_NE(e2, nullptr);
  ASSERT_EQ(e2->removed.size(), 1u);
  EXPECT_EQ(e2->removed[0], GaussianId{100});
  ASSERT_EQ(e2->modified.size(), 1u);
  EXPECT_EQ(e2->modified[0], GaussianId{101});
  EXPECT_TRUE(e2->inserted.empty());

  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(*r) << "a snapshot reusing a removed id was accepted";
  EXPECT_EQ(store.epoch(), Epoch{2});
  ASSERT_EQ(log.lines.size(), 1u);
  EXPECT_NE(log.lines[0].find("never reused"), std::string::npos) << log.lines[0];
}

TEST(SourceSnapshots, LabelsLengthMismatchIsAClearError) {
  const fs::path root = test::fresh_output_dir("source_snapshots/labels");
  write(root / "scene.ply", grid_cloud(10));
  write_text(root / "labels.txt", "1\n2\n3\n");
  SnapshotOptions o;
  o.labels = root / "labels.txt";
  auto src = open_scene_file(root / "scene.ply", o, [](const std::string&) {});
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  auto r = (*src)->next_epoch(store);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("3 labels"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("10 Gaussians"), std::string::npos) << r.message();
  EXPECT_EQ(r.message().find("no usable snapshot"), std::string::npos) << "a scene file alone is no snapshot: " << r.message();
  EXPECT_EQ(store.epoch(), Epoch{0});
  // A matching file works; one PLY is one epoch.
  write_text(root / "labels.txt", "0\n1\n1\n2\n2\n2\n-1\n0\n3\n3\n");
  auto src2 = open_scene_file(root / "scene.ply", o, [](const std::string&) {});
  ASSERT_TRUE(src2.ok());
  ASSERT_TRUE(*(*src2)->next_epoch(store));
  EXPECT_FALSE(*(*src2)->next_epoch(store));
  ASSERT_EQ(store.objects().size(), 3u);
  EXPECT_EQ(store.find_object(ObjectId{2})->members.size(), 3u);
  EXPECT_EQ(store.find_object(ObjectId{0}), nullptr) << "label 0 means unlabelled";
}

TEST(SourceSnapshots, ALabelsFileStaysAlignedWhenTheReaderLeavesAGaussianOut) {
  // Vertex 3 of ten has a NaN: the reader leaves it out, and the labels (one per vertex of
  // the file) skip its line, so every other Gaussian keeps its own label.
  const fs::path root = test::fresh_output_dir("source_snapshots/labels_dropped");
  write_with_nans(root / "scene.ply", grid_cloud(10), [](std::size_t v) { return v == 3; });
  write_text(root / "labels.txt", "0\n1\n1\n2\n2\n2\n-1\n0\n3\n3\n");
  SnapshotOptions o;
  o.labels = root / "labels.txt";
  Collect log;
  auto src = open_scene_file(root / "scene.ply", o, log.log());
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_TRUE(*r);
  EXPECT_EQ(store.size(), 9u);
  EXPECT_EQ(store.find_object(ObjectId{1})->members.size(), 2u);
  EXPECT_EQ(store.find_object(ObjectId{2})->members.size(), 2u) << "vertex 3 (label 2) is the one left out";
  EXPECT_EQ(store.find_object(ObjectId{3})->members.size(), 2u);
  ASSERT_EQ(log.lines.size(), 1u);
  EXPECT_NE(log.lines[0].find("left out 1 of 10 Gaussians with a non-finite value (the first: vertex 3"),
            std::string::npos)
      << log.lines[0];
  // A labels file one short is still a mismatch, counted against the file's vertices.
  write_text(root / "labels.txt", "0\n1\n1\n2\n2\n2\n-1\n0\n3\n");
  auto src2 = open_scene_file(root / "scene.ply", o, [](const std::string&) {});
  ASSERT_TRUE(src2.ok());
  SceneStore store2;
  auto r2 = (*src2)->next_epoch(store2);
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.message().find("has 9 labels but"), std::string::npos) << r2.message();
  EXPECT_NE(r2.message().find("has 10 Gaussians"), std::string::npos) << r2.message();
}

TEST(SourceSnapshots, AFirstSnapshotWithManyNaNsIsAppliedWithoutThemHavingNothingToKeep) {
  const fs::path root = test::fresh_output_dir("source_snapshots/first_nan");
  write_with_nans(root / "snap_1.ply", grid_cloud(30), [](std::size_t v) { return v % 2 == 0; });
  SnapshotOptions settled;
  settled.settle_s = 0.0;
  Collect log;
  auto src = open_snapshot_folder(root, settled, log.log());
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_TRUE(*r);
  EXPECT_EQ(store.size(), 15u) << "half of them NaN, the other half applied";
  ASSERT_EQ(log.lines.size(), 1u);
  EXPECT_NE(log.lines[0].find("left out 15 of 30 Gaussians"), std::string::npos) << log.lines[0];
  SnapshotOptions bad;
  bad.max_non_finite_fraction = 1.5;
  EXPECT_FALSE(open_snapshot_folder(root, bad).ok());
}

TEST(SourceSnapshots, OpenErrors) {
  EXPECT_FALSE(open_snapshot_folder(test::output_dir() / "no_such_folder").ok());
  EXPECT_FALSE(open_scene_file(test::output_dir() / "no_such.ply").ok());
  const fs::path root = test::fresh_output_dir("source_snapshots/badjson");
  write_text(root / "objects.json", "{\"objects\": [");
  auto r = open_snapshot_folder(root);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("objects.json"), std::string::npos) << r.message();
  SnapshotOptions o;
  o.rate_hz = 0.0;
  EXPECT_FALSE(open_snapshot_folder(test::fresh_output_dir("source_snapshots/rate"), o).ok());
  // An empty folder is fine: nothing yet.
  auto empty = open_snapshot_folder(test::fresh_output_dir("source_snapshots/empty"));
  ASSERT_TRUE(empty.ok());
  SceneStore store;
  auto n = (*empty)->next_epoch(store);
  ASSERT_TRUE(n.ok());
  EXPECT_FALSE(*n);
}

TEST(SourceSnapshots, FruitDropsWithLabelsFile) {
  GAUSS_REQUIRE_DATA(ply, "splats/fruit_drops_sh3.ply");
  GAUSS_REQUIRE_DATA(labels, "semantic/fruit_drops_labels.txt");
  SnapshotOptions o;
  o.labels = labels;
  auto src = open_scene_file(ply, o);
  ASSERT_TRUE(src.ok()) << src.message();
  SceneStore store;
  auto r = (*src)->next_epoch(store);
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_TRUE(*r);
  EXPECT_EQ(store.size(), 4721u);
  EXPECT_EQ(store.sh_degree(), 3);
  ASSERT_EQ(store.objects().size(), 8u);
  const std::size_t expected[] = {542, 680, 398, 1038, 616, 396, 556, 266};
  for (int k = 1; k <= 8; ++k) EXPECT_EQ(store.find_object(ObjectId{k})->members.size(), expected[k - 1]) << k;
}

TEST(SourceSnapshots, SyntheticSource) {
  SyntheticSourceOptions o;
  o.scene.target_gaussians = 5000;
  o.scene.epochs = 3;
  o.scene.image_width = 160;
  o.scene.image_height = 120;
  o.scene.focal_px = 120.0;
  o.scene.surface_chunk = true;
  o.rate_hz = 4.0;
  auto src = open_synthetic_source(o);
  ASSERT_TRUE(src.ok()) << src.message();
  EXPECT_DOUBLE_EQ((*src)->epoch_period_s(), 0.25);
  SceneStore store;
  int epochs = 0;
  while (*(*src)->next_epoch(store)) ++epochs;
  EXPECT_EQ(epochs, 3);
  ASSERT_EQ(store.surface_chunks().size(), 1u);
  EXPECT_EQ(store.surface_chunks()[0].epoch, Epoch{1});
  EXPECT_GT(store.appearance_count(), 4000u);
  o.scene.variant = 9;
  EXPECT_FALSE(open_synthetic_source(o).ok());
}

}  // namespace
}  // namespace gauss
