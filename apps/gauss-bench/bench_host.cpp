// gauss-bench host: the host pipeline's costs, each figure beside its error or effect.
//   1. selection + diff per pose update (N eligible, budget M, one thread): median / p90;
//   2. edits per small head motion (5 cm, 2 deg): one step from a settled set, and a
//      continuous walk, as a fraction of M;
//   3. wire bytes per Gaussian (raw, before zstd, and after zstd at several levels) with
//      the quantisation error beside it as PSNR of quantised vs float reference renders;
//   4. identity tracking on an N-Gaussian snapshot (5 % perturbed, 2 % new, 2 % removed,
//      shuffled): kept-id rate and time;
//   5. several clients on one host: K = 1, 2, 4, 8 HostSessions at budget M, each walking
//      its own path, ticked together per pose update the way SessionHost::pump does it
//      (a WorkerPool over the machine's threads): wall ms per update of all K, process
//      CPU ms per client, and wall time relative to K = 1.
//   5b. the same with LoD, the K sessions sharing one hierarchy and the selector's terms (as
//      SessionHost's do): wall ms per pose update of all K, and per epoch that recolours 1 %
//      of the Gaussians (the hierarchy and the terms updated once for all K), with the
//      hierarchy updated by the first tick and in the background (serving thread's ms, and
//      ms until the epoch is sent).
// Prints a table and optionally writes JSON (--json). Timing never decides a test.
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>
#include <zstd.h>

#include <glm/common.hpp>
#include <glm/gtc/quaternion.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss_cli.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/differ.h"
#include "gauss/engine/identity_tracker.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/lod_selector.h"
#include "gauss/engine/selector.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/net/worker_pool.h"
#include "gauss/render/image_metrics.h"
#include "gauss/render/reference_rasterizer.h"

namespace {

using namespace gauss::bench;

using namespace gauss;
namespace fs = std::filesystem;
using nlohmann::json;

// The nearest-rank percentile (apps/common/percentile.h interpolates; these tables never did).
double nearest_rank(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}

struct HostBenchOptions {
  std::size_t gaussians{1'000'000};
  std::size_t budget{200'000};
  int updates{41};
  std::size_t psnr_gaussians{100'000};
  std::uint32_t psnr_width{320};
  std::uint32_t psnr_height{240};
  bool psnr{true};
  bool identity{true};
  bool codec{true};
  bool clients{true};
  bool lod{true};
  std::vector<unsigned> client_counts{1, 2, 4, 8};
  float min_opacity{0.0f};  // part 5b's eligibility filter (0: none)
  fs::path json_out;
};

std::optional<fs::path> data_file(const std::string& rel) {
  // $GAUSS_DATA_DIR, else shared/data beside the checkout (as the tests find it), so
  // the bench finds the real scenes from any working directory.
  fs::path dir = fs::path(__FILE__).parent_path() / ".." / ".." / ".." / "shared" / "data";
  if (const char* env = std::getenv("GAUSS_DATA_DIR"); env && *env) dir = env;
  const fs::path p = dir / rel;
  if (fs::exists(p)) return p;
  return std::nullopt;
}

Expected<SyntheticScene> build_synthetic(std::size_t n, SceneStore& store, double& ms) {
  SyntheticSceneConfig c;
  c.target_gaussians = n;
  c.seed = 7;
  auto scene = SyntheticScene::create(c);
  if (!scene) return scene.error();
  const auto t0 = Clock::now();
  while (!scene->finished()) {
    if (Status st = scene->produce(store); !st) return st.error();
  }
  ms = ms_since(t0);
  return scene;
}

// A 5 cm step forward and a 2 degree turn about the world's up axis (y up in the synthetic
// room; the head frame is OpenCV, y down).
ClientPose small_motion(ClientPose p) {
  const glm::dvec3 forward = p.orientation * glm::dvec3(0.0, 0.0, 1.0);
  p.position += 0.05 * glm::normalize(glm::dvec3(forward.x, 0.0, forward.z));
  p.orientation = glm::angleAxis(2.0 * 3.141592653589793 / 180.0, glm::dvec3(0.0, 1.0, 0.0)) * p.orientation;
  return p;
}

// One row of a median / p90 / max table.
void print_median_p90_max(const char* label, const std::vector<double>& v) {
  std::printf("  %-34s %10.2f %10.2f %10.2f\n", label, nearest_rank(v, 0.5), nearest_rank(v, 0.9), nearest_rank(v, 1.0));
}

// ---- 1 + 2: selection + diff timing, edits per small motion ------------------------------

json bench_select(const SceneStore& store, const SyntheticScene& scene, const HostBenchOptions& o) {
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  SelectionRequest req;
  req.budget = o.budget;
  req.client_capacity = std::max<std::size_t>(o.budget, 400'000);
  Selector selector;
  Differ differ(params);
  ClientPose pose = ClientPose::from_camera(scene.trajectory().front());

  auto t0 = Clock::now();
  auto sel = selector.select(store, pose, req);
  const double cold_select_ms = ms_since(t0);
  if (!sel) {
    std::fprintf(stderr, "select: %s\n", sel.message().c_str());
    return {};
  }
  t0 = Clock::now();
  auto first = differ.diff(*sel, store);
  const double first_diff_ms = ms_since(t0);
  // The same first batch as a host makes it (edit headers: HostSession encodes from the
  // differ's sent records), on a differ of its own.
  double first_headers_ms = 0.0;
  {
    Differ host_differ(params);
    t0 = Clock::now();
    auto headers = host_differ.diff_headers(*sel, store);
    first_headers_ms = ms_since(t0);
    if (!headers || headers->edits.size() != first->edits.size()) {
      std::fprintf(stderr, "first diff as headers: %s\n", headers ? "a different edit count" : headers.message().c_str());
      return {};
    }
  }
  for (int i = 0; i < 2; ++i) {  // settle at the start pose
    (void)differ.diff(*selector.select(store, pose, req), store);
  }
  std::vector<double> select_ms, diff_ms, total_ms, wall_ms, edit_frac;
  // FNV-1a over every selected id and edit of the walk: an optimisation of the selector or
  // differ must leave it unchanged (same scene, same poses, same sets and edits).
  std::uint64_t digest = 0xcbf29ce484222325ull;
  auto mix = [&digest](std::uint64_t v) { digest = (digest ^ v) * 0x100000001b3ull; };
  for (int k = 0; k < o.updates; ++k) {
    pose = small_motion(pose);
    t0 = Clock::now();
    const double c0 = thread_cpu_ms();
    auto s = selector.select(store, pose, req);
    const double c1 = thread_cpu_ms();
    auto b = differ.diff_headers(*s, store);  // as HostSession diffs
    const double c2 = thread_cpu_ms();
    wall_ms.push_back(ms_since(t0));
    select_ms.push_back(c1 - c0);
    diff_ms.push_back(c2 - c1);
    total_ms.push_back(c2 - c0);
    edit_frac.push_back(static_cast<double>(b->edits.size()) / static_cast<double>(o.budget));
    for (GaussianId id : s->ids) mix(to_underlying(id));
    for (const EditHeader& e : b->edits) {
      mix(to_underlying(e.id) * 4 + static_cast<std::uint64_t>(e.kind));
      mix(to_underlying(e.leaving));
    }
  }
  // One small motion from a settled set, at several trajectory poses.
  std::vector<double> one_step;
  const auto& traj = scene.trajectory();
  for (std::size_t c = 0; c < traj.size(); c += std::max<std::size_t>(1, traj.size() / 8)) {
    Selector s2;
    Differ d2(params);
    const ClientPose p = ClientPose::from_camera(traj[c]);
    for (int i = 0; i < 3; ++i) (void)d2.diff(*s2.select(store, p, req), store);
    auto b = d2.diff(*s2.select(store, small_motion(p), req), store);
    one_step.push_back(static_cast<double>(b->edits.size()) / static_cast<double>(o.budget));
  }
  const double eligible = static_cast<double>(sel->background_candidates + sel->object_candidates);
  std::printf("\n== selection + diff per pose update (N = %.0f eligible, M = %zu, one thread) ==\n", eligible,
              o.budget);
  std::printf("  %-34s %10s %10s %10s\n", "(thread CPU time)", "median", "p90", "max");
  print_median_p90_max("select ms", select_ms);
  print_median_p90_max("diff ms", diff_ms);
  print_median_p90_max("select + diff ms (target <= 10)", total_ms);
  print_median_p90_max("select + diff wall ms", wall_ms);
  std::printf("  first call: select %.1f ms (static terms rebuilt), diff %.1f ms (%zu inserts), as edit headers %.1f ms\n",
              cold_select_ms, first_diff_ms, first->edits.size(), first_headers_ms);
  std::printf("  walk digest (selected ids + edits): %016llx\n", static_cast<unsigned long long>(digest));
  // The first diff's batch is the realistic insert batch: M Gaussians chosen by utility
  // out of N, so its ids have gaps (one in N/M is sent). Payload before zstd at SH0.
  CodecParams sh0 = params;
  sh0.sh_degree = 0;
  const auto first_raw = encode_edit_batch_raw(*first, sh0);
  const double first_bpg = static_cast<double>(first_raw.size()) / static_cast<double>(first->edits.size());
  std::printf("  first batch at SH0: %.2f B per Gaussian before zstd (record %zu B + ids, objects, support)\n",
              first_bpg, record_bytes(0));
  std::printf("\n== edits per small head motion (5 cm, 2 deg), fraction of M (target < 1 %%) ==\n");
  std::printf("  one step from a settled set:  median %.3f %%  max %.3f %%  (%zu poses)\n",
              100.0 * nearest_rank(one_step, 0.5), 100.0 * nearest_rank(one_step, 1.0), one_step.size());
  std::printf("  continuous walk (%d steps):    median %.3f %%  max %.3f %%\n", o.updates,
              100.0 * nearest_rank(edit_frac, 0.5), 100.0 * nearest_rank(edit_frac, 1.0));
  return json{{"eligible", eligible},
              {"budget", o.budget},
              {"updates", o.updates},
              {"select_ms", {{"median", nearest_rank(select_ms, 0.5)}, {"p90", nearest_rank(select_ms, 0.9)}}},
              {"diff_ms", {{"median", nearest_rank(diff_ms, 0.5)}, {"p90", nearest_rank(diff_ms, 0.9)}}},
              {"select_diff_ms",
               {{"median", nearest_rank(total_ms, 0.5)}, {"p90", nearest_rank(total_ms, 0.9)}, {"max", nearest_rank(total_ms, 1.0)}}},
              {"select_diff_wall_ms", {{"median", nearest_rank(wall_ms, 0.5)}, {"p90", nearest_rank(wall_ms, 0.9)}}},
              {"timing", "thread CPU time unless named wall"},
              {"cold_select_ms", cold_select_ms},
              {"first_diff_ms", first_diff_ms},
              {"first_diff_headers_ms", first_headers_ms},
              {"walk_digest", digest},
              {"first_batch_sh0_raw_bytes_per_gaussian", first_bpg},
              {"edit_fraction_one_step", {{"median", nearest_rank(one_step, 0.5)}, {"max", nearest_rank(one_step, 1.0)}}},
              {"edit_fraction_walk", {{"median", nearest_rank(edit_frac, 0.5)}, {"max", nearest_rank(edit_frac, 1.0)}}},
        {"walk_digest", digest}};
}

// ---- 2b: the same walk with LoD: hierarchy build, select + cut + diff ----------------------

json bench_lod(const SceneStore& store, const SyntheticScene& scene, const HostBenchOptions& o) {
  const CodecParams params = fit_lod_codec_params(fit_codec_params(store.gaussians(), store.sh_degree()));
  LodSelector lod(store.sh_degree());
  double c0 = thread_cpu_ms();
  if (Status st = lod.update(store, nullptr); !st) {
    std::fprintf(stderr, "LoD: %s\n", st.message().c_str());
    return {};
  }
  const double build_ms = thread_cpu_ms() - c0;
  const LodHierarchy& h = *lod.hierarchy();
  std::printf("\n== LoD: hierarchy and select + cut + diff per pose update (M = %zu, one thread) ==\n", o.budget);
  std::printf("  hierarchy build: %.0f ms thread CPU for %zu leaves (%zu interior nodes, height %u)\n", build_ms,
              h.leaf_count(), h.interior_count(), unsigned(h.node(h.root()).height));
  json out{{"build_ms", build_ms}, {"leaves", h.leaf_count()}, {"interior", h.interior_count()},
           {"timing", "thread CPU time"}};
  // The same walk twice: without a query (the cut is the whole selection), and with the
  // demo's query at the paper's share (chairs, rho 0.9: the reservation's leaves, then the cut
  // over what the query leaves of M).
  for (const bool query : {false, true}) {
    SelectionRequest req;
    req.budget = o.budget;
    req.client_capacity = std::max<std::size_t>(o.budget, 400'000);
    if (query) {
      req.query = SemanticQuery::for_class("chair");
      req.rho = 0.9;
    }
    Selector selector;
    Differ differ(params);
    // FNV-1a over the walk's selections and edits, values included (as the client would
    // decode them): an optimisation of the selector, cut or differ must leave it unchanged.
    std::uint64_t digest = 0xcbf29ce484222325ull;
    auto mix = [&digest](std::uint64_t v) { digest = (digest ^ v) * 0x100000001b3ull; };
    auto mix_value = [&mix](const Gaussian& g) {  // every field the client decodes, by its bits
      auto f = [&mix](float x) { mix(std::bit_cast<std::uint32_t>(x)); };
      for (int a = 0; a < 3; ++a) {
        f(g.position[a]);
        f(g.log_scale[a]);
        f(g.sh_dc[a]);
        for (const glm::vec3& c : g.sh_rest) f(c[a]);
      }
      for (int a = 0; a < 4; ++a) f(g.rotation[a]);
      f(g.opacity_logit);
      mix(std::uint64_t(std::uint32_t(to_underlying(g.object))) << 32 | g.support);
    };
    // The batch and payload as a host makes them (edit headers, encoded from the differ's
    // sent records, as HostSession does): the payload's bytes in a digest of their own, its
    // time beside the diff's.
    std::uint64_t payload_digest = 0xcbf29ce484222325ull;
    auto step = [&](const ClientPose& p, double* times) -> Expected<EditHeaderBatch> {
      const double t0 = thread_cpu_ms();
      auto sel = lod.select(selector, store, nullptr, p, req);
      if (!sel) return sel.error();
      const double t1 = thread_cpu_ms();
      auto b = differ.diff_headers(*sel, store, lod.records(), lod.modified());
      lod.clear_modified();
      const double t2 = thread_cpu_ms();
      if (!b) return b;
      auto encoded = encode_edit_headers(*b, params, differ.last_sent_records());
      if (!encoded) return encoded.error();
      const std::vector<std::uint8_t>& payload = *encoded;
      const double t3 = thread_cpu_ms();
      if (times) {
        times[0] = t1 - t0;
        times[1] = t2 - t1;
        times[2] = t3 - t2;
        for (GaussianId id : sel->ids) mix(to_underlying(id));
        for (std::uint8_t byte : payload) payload_digest = (payload_digest ^ byte) * 0x100000001b3ull;
      }
      return b;
    };
    ClientPose pose = ClientPose::from_camera(scene.trajectory().front());
    for (int i = 0; i < 3; ++i)  // the first batch, then settle at the start pose
      if (auto b = step(pose, nullptr); !b) {
        std::fprintf(stderr, "LoD step: %s\n", b.message().c_str());
        return {};
      }
    std::vector<double> select_ms, diff_ms, total_ms, encode_ms, served_ms, edit_frac;
    for (int k = 0; k < o.updates; ++k) {
      pose = small_motion(pose);
      double t[3];
      auto b = step(pose, t);
      if (!b) return {};
      // Each value edit as the client decodes it: its sent record (read_sent_record gives
      // what quantize_roundtrip of its value gives).
      const std::uint8_t* record = differ.last_sent_records().data();
      const std::size_t stride = sent_record_bytes(params.sh_degree);
      for (const EditHeader& e : b->edits) {
        mix(to_underlying(e.id) * 4 + static_cast<std::uint64_t>(e.kind));
        mix(to_underlying(e.leaving));
        if (e.kind == EditKind::Remove) continue;
        mix_value(read_sent_record(record, e.id, params));
        record += stride;
      }
      select_ms.push_back(t[0]);
      diff_ms.push_back(t[1]);
      total_ms.push_back(t[0] + t[1]);
      encode_ms.push_back(t[2]);
      served_ms.push_back(t[0] + t[1] + t[2]);
      edit_frac.push_back(static_cast<double>(b->edits.size()) / static_cast<double>(o.budget));
    }
    const LodCut& cut = lod.last_cut();
    std::printf("  -- %s: last cut %zu nodes, %zu of them interior, %zu refined\n",
                query ? "query 'chair', rho 0.9" : "no query", cut.nodes.size(), cut.interior, cut.refined);
    std::printf("  %-34s %10s %10s %10s\n", "(thread CPU time)", "median", "p90", "max");
    // The reservation's leaves and the cut; the Selector does not rank the background the
    // cut replaces (LodSelector::select with a Selector).
    print_median_p90_max("select (reservation + cut) ms", select_ms);
    print_median_p90_max("diff ms", diff_ms);
    print_median_p90_max("select + cut + diff ms (<= 10)", total_ms);
    print_median_p90_max("encode ms (records, columns, zstd)", encode_ms);
    print_median_p90_max("select + cut + diff + encode ms", served_ms);
    std::printf("  edits per step (walk): median %.3f %%  max %.3f %% of M\n", 100.0 * nearest_rank(edit_frac, 0.5),
                100.0 * nearest_rank(edit_frac, 1.0));
    std::printf("  walk digest (selected ids + edits + values): %016llx\n", static_cast<unsigned long long>(digest));
    std::printf("  payload digest (encoded batches):            %016llx\n", static_cast<unsigned long long>(payload_digest));
    out[query ? "query" : "no_query"] = json{
        {"cut_nodes", cut.nodes.size()},
        {"cut_interior", cut.interior},
        {"select_ms", {{"median", nearest_rank(select_ms, 0.5)}, {"p90", nearest_rank(select_ms, 0.9)}}},
        {"diff_ms", {{"median", nearest_rank(diff_ms, 0.5)}, {"p90", nearest_rank(diff_ms, 0.9)}}},
        {"select_cut_diff_ms",
         {{"median", nearest_rank(total_ms, 0.5)}, {"p90", nearest_rank(total_ms, 0.9)}, {"max", nearest_rank(total_ms, 1.0)}}},
        {"encode_ms", {{"median", nearest_rank(encode_ms, 0.5)}, {"p90", nearest_rank(encode_ms, 0.9)}}},
        {"select_cut_diff_encode_ms",
         {{"median", nearest_rank(served_ms, 0.5)}, {"p90", nearest_rank(served_ms, 0.9)}, {"max", nearest_rank(served_ms, 1.0)}}},
        {"edit_fraction_walk", {{"median", nearest_rank(edit_frac, 0.5)}, {"max", nearest_rank(edit_frac, 1.0)}}},
        {"payload_digest", payload_digest}};
  }
  return out;
}

// ---- 3: wire bytes and quantisation PSNR -------------------------------------------------

struct CodecCase {
  std::string name;
  std::vector<Gaussian> gaussians;
  int sh_degree{0};
  std::vector<Camera> cameras;  // for PSNR; empty = no PSNR
};

// A camera looking along +z at the bounds of a PLY scene, from 1.2 extents back.
Camera camera_for(std::span<const Gaussian> g, std::uint32_t w, std::uint32_t h) {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Gaussian& x : g) {
    lo = glm::min(lo, x.position);
    hi = glm::max(hi, x.position);
  }
  const glm::dvec3 c = 0.5 * (glm::dvec3(lo) + glm::dvec3(hi));
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, 1e-3f});
  Camera cam;
  cam.width = w;
  cam.height = h;
  cam.fx = cam.fy = 0.9 * w;
  cam.cx = 0.5 * w;
  cam.cy = 0.5 * h;
  const glm::dvec3 eye = c - glm::dvec3(0.0, 0.0, 1.2 * extent + 0.5 * (hi.z - lo.z));
  cam.world_to_camera = glm::dmat4(1.0);
  cam.world_to_camera[3] = glm::dvec4(-eye, 1.0);
  cam.near_plane = 0.01;
  return cam;
}

json bench_codec_case(const CodecCase& cc, const HostBenchOptions& o) {
  const CodecParams params = fit_codec_params(cc.gaussians, cc.sh_degree);
  EditBatch batch;
  batch.epoch = Epoch{1};
  batch.edits.reserve(cc.gaussians.size());
  for (const Gaussian& g : cc.gaussians) batch.edits.push_back(Edit{EditKind::Insert, g.id, GaussianId{0}, g});
  CodecStats stats;
  double c0 = thread_cpu_ms();
  const auto raw = encode_edit_batch_raw(batch, params, &stats);
  const double raw_ms = thread_cpu_ms() - c0;
  const double n = static_cast<double>(cc.gaussians.size());
  json levels = json::array();
  // raw = records + the id / object / support columns and the header, before zstd.
  const double columns = static_cast<double>(raw.size()) / n - static_cast<double>(record_bytes(cc.sh_degree));
  std::printf("  %-22s SH%d  %8zu G  record %zu B  raw %.2f B/G (columns %.2f)  (encode %.1f ms CPU, %llu clamped)\n",
              cc.name.c_str(), cc.sh_degree, cc.gaussians.size(), record_bytes(cc.sh_degree),
              static_cast<double>(raw.size()) / n, columns, raw_ms, static_cast<unsigned long long>(stats.clamped_total()));
  for (int level : {1, 3, 9, 19}) {
    std::vector<std::uint8_t> z(ZSTD_compressBound(raw.size()));
    c0 = thread_cpu_ms();
    const std::size_t zn = ZSTD_compress(z.data(), z.size(), raw.data(), raw.size(), level);
    const double zms = thread_cpu_ms() - c0;
    if (ZSTD_isError(zn)) continue;
    std::printf("      zstd %-2d %s %6.2f B/G  %8.1f ms CPU\n", level, level == kZstdLevel ? "(used)" : "      ",
                static_cast<double>(zn) / n, zms);
    levels.push_back({{"level", level}, {"bytes_per_gaussian", static_cast<double>(zn) / n}, {"ms", zms}});
  }
  const auto wire = encode_edit_batch(batch, params);
  c0 = thread_cpu_ms();
  auto decoded = decode_edit_batch(wire, params);
  const double decode_ms = thread_cpu_ms() - c0;
  std::printf("      decode (zstd + records) %.1f ms CPU, %s\n", decode_ms, decoded.ok() ? "ok" : decoded.message().c_str());
  json out{{"name", cc.name},
           {"sh_degree", cc.sh_degree},
           {"gaussians", cc.gaussians.size()},
           {"record_bytes", record_bytes(cc.sh_degree)},
           {"raw_bytes_per_gaussian", static_cast<double>(raw.size()) / n},
           {"column_bytes_per_gaussian", columns},
           {"wire_bytes_per_gaussian", static_cast<double>(wire.size()) / n},
           {"encode_raw_ms", raw_ms},
           {"decode_ms", decode_ms},
           {"decode_ok", decoded.ok()},
           {"clamped", stats.clamped_total()},
           {"zstd", levels}};
  if (!o.psnr || cc.cameras.empty()) return out;
  std::vector<Gaussian> quantised;
  quantised.reserve(cc.gaussians.size());
  for (const Gaussian& g : cc.gaussians) quantised.push_back(quantize_roundtrip(g, params));
  json psnrs = json::array();
  render::ReferenceOptions ro;
  ro.threads = 2;
  for (const Camera& cam : cc.cameras) {
    const auto t0 = Clock::now();
    auto a = render::render_reference(cc.gaussians, {}, cc.sh_degree, cam, ro);
    auto b = render::render_reference(quantised, {}, cc.sh_degree, cam, ro);
    const double rms = ms_since(t0);
    if (!a || !b) {
      std::fprintf(stderr, "reference render failed: %s\n", (!a ? a.message() : b.message()).c_str());
      continue;
    }
    auto d = render::compare_images(a->rgba8, b->rgba8);
    if (!d) continue;
    std::printf("      PSNR quantised vs float %ux%u: %6.2f dB  (max abs err %d, %llu visible splats, %.0f ms)\n",
                cam.width, cam.height, d->psnr_db, d->max_abs_error,
                static_cast<unsigned long long>(a->stats.visible), rms);
    psnrs.push_back({{"psnr_db", std::isfinite(d->psnr_db) ? d->psnr_db : 999.0},
                     {"max_abs_error", d->max_abs_error},
                     {"visible", a->stats.visible}});
  }
  out["psnr"] = psnrs;
  return out;
}

json bench_codec(const SceneStore& big, const HostBenchOptions& o) {
  std::printf("\n== wire bytes per Gaussian (SH0 target <= 16 B before zstd) and quantisation PSNR (target >= 45 dB) ==\n");
  std::vector<CodecCase> cases;
  {  // the synthetic room, smaller so the double-precision reference stays affordable
    SceneStore store;
    double ms = 0.0;
    auto scene = build_synthetic(o.psnr_gaussians, store, ms);
    if (scene) {
      CodecCase c1{"synthetic room", {}, store.sh_degree(), {}};
      for (const Gaussian& g : store.gaussians())
        if (!g.carrier) c1.gaussians.push_back(g);
      const auto& traj = scene->trajectory();
      for (std::size_t k : {std::size_t{0}, traj.size() / 2}) {
        Camera cam = traj[k];
        const double s = static_cast<double>(o.psnr_width) / cam.width;
        cam.fx *= s;
        cam.fy *= s;
        cam.cx *= s;
        cam.cy *= s;
        cam.width = o.psnr_width;
        cam.height = static_cast<std::uint32_t>(std::lround(cam.height * s));
        c1.cameras.push_back(cam);
      }
      CodecCase c0 = c1;
      c0.name = "synthetic room";
      c0.sh_degree = 0;
      for (Gaussian& g : c0.gaussians) g.sh_rest = {};
      cases.push_back(std::move(c0));
      cases.push_back(std::move(c1));
    }
  }
  for (const auto& [rel, label] : {std::pair{"splats/guitar.ply", "guitar (real)"},
                                  std::pair{"splats/fruit_drops_sh3.ply", "fruit_drops (real)"}}) {
    auto p = data_file(rel);
    if (!p) {
      std::printf("  %s: not found under GAUSS_DATA_DIR / ../shared/data, skipped\n", rel);
      continue;
    }
    auto ply = read_gaussian_ply(*p);
    if (!ply) {
      std::printf("  %s: %s\n", rel, ply.message().c_str());
      continue;
    }
    CodecCase c{label, std::move(ply->cloud.gaussians), ply->cloud.sh_degree, {}};
    for (std::size_t i = 0; i < c.gaussians.size(); ++i) c.gaussians[i].id = GaussianId{i + 1};
    c.cameras.push_back(camera_for(c.gaussians, o.psnr_width, o.psnr_height));
    cases.push_back(std::move(c));
  }
  {  // the big scene's wire size at SH0 (no PSNR: too large for the reference)
    CodecCase c{"synthetic room (big)", {}, 0, {}};
    for (const Gaussian& g : big.gaussians()) {
      if (g.carrier) continue;
      c.gaussians.push_back(g);
      c.gaussians.back().sh_rest = {};
      if (c.gaussians.size() == o.budget) break;
    }
    cases.push_back(std::move(c));
  }
  json out = json::array();
  for (const CodecCase& c : cases) out.push_back(bench_codec_case(c, o));
  return out;
}

// ---- 4: identity tracking ------------------------------------------------------------

json bench_identity(const SceneStore& store) {
  std::vector<Gaussian> previous;
  for (const Gaussian& g : store.gaussians())
    if (!g.carrier) previous.push_back(g);
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Gaussian> current;
  std::vector<GaussianId> truth;  // the id each snapshot Gaussian should keep (0: new)
  std::size_t unchanged = 0;
  for (const Gaussian& g : previous) {
    const float r = u(rng);
    if (r < 0.02f) continue;  // removed
    Gaussian c = g;
    if (r < 0.07f) {  // perturbed: a fraction of a sigma, small colour / opacity change
      const float sigma = std::exp(std::max({g.log_scale.x, g.log_scale.y, g.log_scale.z}));
      c.position += sigma * 0.3f * glm::vec3{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f};
      c.sh_dc += 0.05f * glm::vec3(u(rng) - 0.5f);
      c.opacity_logit += 0.2f * (u(rng) - 0.5f);
    }
    current.push_back(c);
    truth.push_back(g.id);
    ++unchanged;
  }
  const std::size_t n_new = previous.size() / 50;
  for (std::size_t i = 0; i < n_new; ++i) {
    Gaussian c = previous[rng() % previous.size()];
    c.position += glm::vec3{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f};  // a different place
    current.push_back(c);
    truth.push_back(GaussianId{0});
  }
  std::vector<std::size_t> perm(current.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<Gaussian> shuffled(current.size());
  std::vector<GaussianId> truth_shuffled(current.size());
  for (std::size_t i = 0; i < perm.size(); ++i) {
    shuffled[i] = current[perm[i]];
    truth_shuffled[i] = truth[perm[i]];
  }
  std::uint64_t next = 1ull << 40;
  const auto t0 = Clock::now();
  auto rep = track_identity(previous, shuffled, IdentityTrackerConfig{}, [&] { return GaussianId{next++}; });
  const double ms = ms_since(t0);
  if (!rep) {
    std::printf("\n== identity tracking: %s ==\n", rep.message().c_str());
    return {{"error", rep.message()}};
  }
  std::size_t kept_right = 0;
  for (std::size_t i = 0; i < shuffled.size(); ++i) {
    kept_right += to_underlying(truth_shuffled[i]) != 0 && shuffled[i].id == truth_shuffled[i];
  }
  const double rate = static_cast<double>(kept_right) / static_cast<double>(unchanged);
  std::printf("\n== identity tracking (%zu previous, 5 %% perturbed, 2 %% new, 2 %% removed, shuffled) ==\n",
              previous.size());
  std::printf("  kept-id rate of surviving Gaussians: %.4f   time %.0f ms   (fresh %zu, removed %zu)\n", rate, ms,
              rep->fresh, rep->removed);
  return {{"previous", previous.size()}, {"kept_rate", rate}, {"ms", ms}, {"fresh", rep->fresh},
          {"removed", rep->removed}};
}

// ---- 5. several clients ---------------------------------------------------------------

// One client's session as the host holds it, and where it looks.
struct BenchClient {
  std::unique_ptr<HostSession> session;
  ClientPose pose;
  std::uint32_t sequence{0};
  std::vector<wire::Message> out;
  Status error{Ok{}};
};

// The wire form of a selector pose (the inverse of to_client_pose).
msg::HeadPose head_pose_of(const ClientPose& c) {
  msg::HeadPose h;
  h.position = glm::vec3(c.position);
  const glm::dquat q = glm::normalize(c.orientation);
  h.rotation = glm::vec4(static_cast<float>(q.w), static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z));
  h.tan_half_fov_x = static_cast<float>(c.tan_half_fov_x);
  h.tan_half_fov_y = static_cast<float>(c.tan_half_fov_y);
  return h;
}

// Feeds the client's pose (and acks what it was sent, as a client that keeps up does).
void feed(BenchClient& c, const SceneStore& store, double now) {
  for (const wire::Message& m : c.out)
    if (const auto* b = std::get_if<msg::EditBatchMsg>(&m))
      (void)c.session->on_message(wire::Message{msg::Ack{b->batch_id, b->epoch, b->epoch}}, store, now);
  msg::HeadPose p = head_pose_of(c.pose);
  p.sequence = ++c.sequence;
  p.client_time_us = static_cast<std::uint64_t>(now * 1e6);
  (void)c.session->on_message(wire::Message{p}, store, now);
}

// K sessions, each welcomed and looking from its own point of the trajectory.
std::vector<BenchClient> connect_clients(unsigned k, const CodecParams& params, const HostSessionConfig& cfg,
                                         const SceneStore& store, const std::vector<Camera>& path, std::size_t budget,
                                         const std::string& name) {
  std::vector<BenchClient> clients(k);
  for (unsigned i = 0; i < k; ++i) {
    clients[i].session = std::make_unique<HostSession>(i + 1, 1, params, cfg);
    clients[i].pose = ClientPose::from_camera(path[(i * path.size()) / std::max(1u, k)]);
    msg::Hello hello;
    hello.slot_capacity = static_cast<std::uint32_t>(budget);
    hello.client_name = name + std::to_string(i);
    (void)clients[i].session->on_message(wire::Message{hello}, store, 0.0);
  }
  return clients;
}

json bench_clients(const SceneStore& store, const SyntheticScene& scene, const HostBenchOptions& o) {
  net::WorkerPool pool(0);
  std::printf("\n5. several clients, one host (M = %zu each, %u threads tick the sessions; wall and process CPU)\n",
              o.budget, pool.threads());
  std::printf("   %8s %14s %14s %16s %10s\n", "clients", "update ms p50", "update ms p90", "CPU ms / client", "wall / K=1");
  const CodecParams params = fit_codec_params(store.gaussians(), store.sh_degree());
  HostSessionConfig cfg;
  cfg.pose_smoothing_s = 0.0;  // every step of the walk re-selects (no sway rejection)
  cfg.pose_epsilon_m = 0.01;
  cfg.shared_selector_terms = std::make_shared<SelectorTerms>();  // as SessionHost's sessions
  json rows = json::array();
  double base_ms = 0.0;
  const auto& path = scene.trajectory();
  for (unsigned k : o.client_counts) {
    double now = 0.0;
    std::vector<BenchClient> clients = connect_clients(k, params, cfg, store, path, o.budget, "bench-");
    auto tick_all = [&] {
      for (BenchClient& c : clients) feed(c, store, now);
      pool.parallel_for(clients.size(), [&](std::size_t i) {
        auto r = clients[i].session->tick(store, now);
        if (r) clients[i].out = std::move(r).value();
        else clients[i].error = r.error();
      });
      now += 0.1;
    };
    for (int settle = 0; settle < 3; ++settle) tick_all();  // the first selection and full batch
    std::vector<double> wall_ms;
    double cpu_ms = 0.0;
    for (int u = 0; u < std::max(3, o.updates / 2); ++u) {
      for (BenchClient& c : clients) c.pose = small_motion(c.pose);
      const auto t0 = Clock::now();
      const double c0 = process_cpu_ms();
      tick_all();
      cpu_ms += process_cpu_ms() - c0;
      wall_ms.push_back(ms_since(t0));
    }
    for (const BenchClient& c : clients)
      if (!c.error) {
        std::fprintf(stderr, "bench clients: %s\n", c.error.message().c_str());
        return json{{"error", c.error.message()}};
      }
    const double p50 = nearest_rank(wall_ms, 0.5), p90 = nearest_rank(wall_ms, 0.9);
    const double per_client = cpu_ms / static_cast<double>(wall_ms.size()) / k;
    if (k == o.client_counts.front()) base_ms = p50;
    std::printf("   %8u %14.1f %14.1f %16.1f %10.2f\n", k, p50, p90, per_client, p50 / std::max(base_ms, 1e-9));
    rows.push_back(json{{"clients", k},
                        {"update_wall_ms_p50", p50},
                        {"update_wall_ms_p90", p90},
                        {"cpu_ms_per_client_per_update", per_client},
                        {"wall_relative_to_first", p50 / std::max(base_ms, 1e-9)},
                        {"updates", wall_ms.size()}});
  }
  return json{{"threads", pool.threads()}, {"budget", o.budget}, {"rows", rows}};
}

// The same with LoD, the sessions sharing one hierarchy as SessionHost's do: pose updates,
// then epochs that recolour 1 % of the Gaussians, the hierarchy updated once per epoch for all
// K. Twice: updated by whichever session ticks first (the serving thread waits for it), and
// updated in the background (SessionHost's way: the serving thread copies the changes out and
// the sessions wait; "served" is the time until they have sent the epoch, "take-up" the
// serving thread's tick that sends it). Leaves the store at a later epoch.
json bench_clients_lod(SceneStore& store, const SyntheticScene& scene, const HostBenchOptions& o) {
  net::WorkerPool pool(0);
  std::printf("\n5b. several clients with LoD, one shared hierarchy (M = %zu each, %u threads; wall ms)\n", o.budget,
              pool.threads());
  if (o.min_opacity > 0.0f) std::printf("   sessions filter eligibility: min opacity %g\n", double(o.min_opacity));
  std::printf("   %8s %12s %12s %14s %14s %16s %16s %16s\n", "clients", "pose p50", "pose p90", "1 % epoch p50",
              "1 % epoch max", "bg: serving p50", "bg: served p50", "bg: take-up p50");
  const CodecParams params = fit_lod_codec_params(fit_codec_params(store.gaussians(), store.sh_degree()));
  json rows = json::array();
  const auto& path = scene.trajectory();
  std::uint64_t seed = 1;
  auto recolour_one_percent = [&] {
    if (!store.begin_next_epoch()) return false;
    std::mt19937_64 rng(seed++);
    std::vector<Gaussian> edits;
    for (const Gaussian& g : store.gaussians())
      if (!g.carrier && rng() % 100 == 0) edits.push_back(g);
    for (Gaussian& g : edits) {
      g.sh_dc.x = -g.sh_dc.x;
      (void)store.modify(g);
    }
    return store.commit_epoch().ok();
  };
  for (unsigned k : o.client_counts) {
    std::vector<double> pose_ms, epoch_ms, serving_ms, served_ms, take_up_ms;
    double first_build_serving_ms = 0.0, first_build_ready_ms = 0.0;
    for (const bool background : {false, true}) {
      HostSessionConfig cfg;
      cfg.pose_smoothing_s = 0.0;
      cfg.pose_epsilon_m = 0.01;
      cfg.lod = LodConfig{};
      cfg.shared_lod = std::make_shared<LodEpochHierarchy>(store.sh_degree(), *cfg.lod);
      cfg.lod_in_background = background;
      cfg.shared_selector_terms = std::make_shared<SelectorTerms>();
      if (o.min_opacity > 0.0f) {
        cfg.eligibility = EligibilityConfig{};
        cfg.eligibility->min_opacity = o.min_opacity;
        cfg.shared_eligible = std::make_shared<SharedEligibleSet>(*cfg.eligibility);  // as SessionHost does
      }
      LodEpochHierarchy& hierarchy = *cfg.shared_lod;
      double now = 0.0;
      std::vector<BenchClient> clients = connect_clients(k, params, cfg, store, path, o.budget, "bench-lod-");
      auto tick_all = [&] {
        for (BenchClient& c : clients) feed(c, store, now);
        const auto t0 = Clock::now();
        pool.parallel_for(clients.size(), [&](std::size_t i) {
          auto r = clients[i].session->tick(store, now);
          if (r) clients[i].out = std::move(r).value();
          else clients[i].error = r.error();
        });
        now += 0.1;
        return ms_since(t0);
      };
      // The host loop's part: start the update, or take a finished one up.
      auto advance = [&] {
        auto p = hierarchy.update_in_background(store, cfg.eligibility ? &*cfg.eligibility : nullptr);
        return p && *p == LodEpochHierarchy::Progress::Ready;
      };
      auto settle = [&] {
        for (int tries = 0; background && tries < 3 && !advance(); ++tries) hierarchy.wait_idle();
      };
      if (background) {
        // The first build: the serving thread copies the scene out, the worker builds.
        const auto t0 = Clock::now();
        advance();
        first_build_serving_ms = ms_since(t0);
        settle();
        first_build_ready_ms = ms_since(t0);
      }
      for (int s = 0; s < 3; ++s) tick_all();  // the build, the first cuts and full batches
      if (!background)
        for (int u = 0; u < std::max(3, o.updates / 2); ++u) {
          for (BenchClient& c : clients) c.pose = small_motion(c.pose);
          pose_ms.push_back(tick_all());
        }
      for (int e = 0; e < 4; ++e) {
        if (!recolour_one_percent()) break;
        if (!background) {
          epoch_ms.push_back(tick_all());
          continue;
        }
        const auto t0 = Clock::now();
        advance();        // copies the changes out and starts the worker
        (void)tick_all(); // the sessions find it at work and send nothing
        serving_ms.push_back(ms_since(t0));
        settle();
        take_up_ms.push_back(tick_all());
        served_ms.push_back(ms_since(t0));
      }
      for (const BenchClient& c : clients)
        if (!c.error) {
          std::fprintf(stderr, "bench clients (LoD): %s\n", c.error.message().c_str());
          return json{{"error", c.error.message()}};
        }
    }
    auto p50 = [](const std::vector<double>& v) { return v.empty() ? 0.0 : nearest_rank(v, 0.5); };
    const double emax = epoch_ms.empty() ? 0.0 : *std::max_element(epoch_ms.begin(), epoch_ms.end());
    std::printf("   %8u %12.1f %12.1f %14.1f %14.1f %16.1f %16.1f %16.1f\n", k, p50(pose_ms), nearest_rank(pose_ms, 0.9),
                p50(epoch_ms), emax, p50(serving_ms), p50(served_ms), p50(take_up_ms));
    std::printf("   %8s first build in the background: serving thread %.1f ms (the scene copied out), ready after %.1f ms\n",
                "", first_build_serving_ms, first_build_ready_ms);
    rows.push_back(json{{"clients", k},
                        {"pose_update_wall_ms_p50", p50(pose_ms)},
                        {"pose_update_wall_ms_p90", nearest_rank(pose_ms, 0.9)},
                        {"epoch_1pct_wall_ms_p50", p50(epoch_ms)},
                        {"epoch_1pct_wall_ms_max", emax},
                        {"epoch_1pct_background_serving_thread_ms_p50", p50(serving_ms)},
                        {"epoch_1pct_background_served_ms_p50", p50(served_ms)},
                        {"epoch_1pct_background_take_up_tick_ms_p50", p50(take_up_ms)},
                        {"first_build_background_serving_thread_ms", first_build_serving_ms},
                        {"first_build_background_ready_ms", first_build_ready_ms},
                        {"epochs", epoch_ms.size()}});
  }
  return json{{"threads", pool.threads()}, {"budget", o.budget}, {"rows", rows}};
}

int bench_host_main(const HostBenchOptions& o) {
  SceneStore store;
  double build_ms = 0.0;
  auto scene = build_synthetic(o.gaussians, store, build_ms);
  if (!scene) {
    std::fprintf(stderr, "synthetic scene: %s\n", scene.message().c_str());
    return 1;
  }
  std::printf("synthetic room: %zu appearance Gaussians (+%zu carriers), SH%d, %zu epochs built in %.0f ms\n",
              store.appearance_count(), store.carrier_count(), store.sh_degree(),
              static_cast<std::size_t>(scene->epoch_count()), build_ms);
  json out;
  out["scene"] = {{"appearance", store.appearance_count()}, {"build_ms", build_ms}};
  out["zstd_level"] = kZstdLevel;
  out["select"] = bench_select(store, *scene, o);
  if (o.lod) out["lod"] = bench_lod(store, *scene, o);
  if (o.codec) out["codec"] = bench_codec(store, o);
  if (o.identity) out["identity"] = bench_identity(store);
  if (o.clients) out["clients"] = bench_clients(store, *scene, o);
  if (o.clients && o.lod) out["clients_lod"] = bench_clients_lod(store, *scene, o);
  if (!o.json_out.empty() && !write_json(o.json_out, out, "host")) return 1;
  return 0;
}

BenchRun bench_host_setup(CLI::App& cmd) {
  auto o = std::make_shared<HostBenchOptions>();
  cmd.add_option("--gaussians", o->gaussians, "eligible Gaussians of the synthetic room")
      ->check(gauss::apps::at_least<std::size_t>(1))
      ->type_name("N");
  cmd.add_option("--budget", o->budget, "M: the client's budget")->check(gauss::apps::at_least<std::size_t>(1))->type_name("M");
  cmd.add_option("--updates", o->updates, "steps of the continuous head walk")->check(gauss::apps::at_least(1))->type_name("K");
  cmd.add_option("--psnr-gaussians", o->psnr_gaussians, "Gaussians of the scene the quantisation PSNR is measured on")
      ->check(gauss::apps::at_least<std::size_t>(1))
      ->type_name("N");
  cmd.add_option_function<std::string>(
         "--psnr-size", [o](const std::string& s) { std::tie(o->psnr_width, o->psnr_height) = *gauss::apps::parse_size(s); },
         "size of the PSNR renders")
      ->check(gauss::apps::image_size())
      ->default_str(std::to_string(o->psnr_width) + "x" + std::to_string(o->psnr_height));
  cmd.add_flag_callback("--no-psnr", [o] { o->psnr = false; }, "skip the quantisation PSNR renders");
  cmd.add_flag_callback("--no-codec", [o] { o->codec = false; }, "skip the wire-bytes part");
  cmd.add_flag_callback("--no-identity", [o] { o->identity = false; }, "skip identity tracking");
  cmd.add_flag_callback("--no-clients", [o] { o->clients = false; }, "skip the several-clients part");
  cmd.add_flag_callback("--no-lod", [o] { o->lod = false; }, "skip the LoD hierarchy and cut part");
  cmd.add_option("--clients", o->client_counts, "client counts of the several-clients part")
      ->delimiter(',')
      ->check(gauss::apps::in_range(1u, 64u))
      ->type_name("K,...");
  cmd.add_option("--min-opacity", o->min_opacity, "part 5b: the sessions' eligibility filter (0: none)")
      ->check(gauss::apps::in_range(0.0f, 1.0f))
      ->type_name("P");
  cmd.add_option("--json", o->json_out, "write the results as JSON")->type_name("FILE");
  return [o] { return bench_host_main(*o); };
}

}  // namespace

GAUSS_BENCH("host", "host pipeline: select+diff ms, edits per head motion, wire bytes + PSNR, identity tracking",
            bench_host_setup);
