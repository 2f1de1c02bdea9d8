// gauss-bench render: the splat renderer on the "box" scene (/work/shared/bench/box_scene.c,
// ported here draw for draw), GPU ms per pass and wall ms per frame, each beside the error
// of the frame against the CPU reference rasterizer (PSNR, max abs error).
//
// Sizes are "N@WxH" (N with k/M suffixes) or "N@WxH:stereo" (two eyes, 64 mm apart, one
// render_stereo call per frame); "capture@WxH" renders the --capture file instead of the box
// scene, placed in front of the same camera (bench_capture.h), at its own SH degree.
// Cameras: shared/bench/box_camera_WxH.json when it exists, else the 1280x720 one rescaled
// keeping its horizontal field of view, square pixels and the principal point at the image
// centre (equal to the file cameras at their sizes).
// Timing never decides a test; this prints a table and optionally writes JSON.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <zlib.h>

#include "bench_box.h"
#include "bench_capture.h"
#include "bench_peer.h"
#include "bench_registry.h"
#include "bench_util.h"
#include "gauss_cli.h"
#include "gauss/engine/camera_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/render/image_metrics.h"
#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"

namespace {

using namespace gauss::bench;

using namespace gauss;
namespace fs = std::filesystem;

// ---- Configurations ------------------------------------------------------------------------

struct Config {
  std::string label;
  long n{0};
  std::uint32_t width{0}, height{0};
  bool stereo{false};
  bool capture{false};  // "capture@WxH": the --capture file; n is its size once loaded
  int sh_degree{3};     // the box scene's; a capture's own
};

std::optional<long> parse_count(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  double mul = 1.0;
  const std::string suffix(end);
  if (suffix == "k" || suffix == "K") mul = 1e3;
  else if (suffix == "m" || suffix == "M") mul = 1e6;
  else if (!suffix.empty()) return std::nullopt;
  const double n = v * mul;
  if (!std::isfinite(n) || n < 1 || n > 1e8 || n != std::floor(n)) return std::nullopt;
  return long(n);
}

std::optional<Config> parse_config(const std::string& s) {
  Config c;
  c.label = s;
  std::string body = s;
  if (const auto colon = body.find(':'); colon != std::string::npos) {
    if (body.substr(colon) != ":stereo") return std::nullopt;
    c.stereo = true;
    body = body.substr(0, colon);
  }
  const auto at = body.find('@'), x = body.find('x', at == std::string::npos ? 0 : at);
  if (at == std::string::npos || x == std::string::npos) return std::nullopt;
  const std::string count = body.substr(0, at);
  c.capture = count == "capture";
  const auto n = c.capture ? std::optional<long>(1) : parse_count(count);
  char* end = nullptr;
  const std::string ws = body.substr(at + 1, x - at - 1), hs = body.substr(x + 1);
  const long w = std::strtol(ws.c_str(), &end, 10);
  if (ws.empty() || *end) return std::nullopt;
  const long h = std::strtol(hs.c_str(), &end, 10);
  if (hs.empty() || *end || !n || w < 16 || h < 16 || w > 4096 || h > 4096) return std::nullopt;
  c.n = *n;
  c.width = std::uint32_t(w);
  c.height = std::uint32_t(h);
  return c;
}

Expected<Camera> box_camera(const fs::path& dir, std::uint32_t w, std::uint32_t h) {
  const fs::path exact = dir / ("box_camera_" + std::to_string(w) + "x" + std::to_string(h) + ".json");
  if (fs::exists(exact)) return read_camera_json(exact);
  auto base = read_camera_json(dir / "box_camera_1280x720.json");
  if (!base) return base.error();
  Camera c = *base;
  const double s = double(w) / double(base->width);
  c.width = w;
  c.height = h;
  c.fx = base->fx * s;
  c.fy = base->fx * s;
  c.cx = 0.5 * w;
  c.cy = 0.5 * h;
  return c;
}

// The peer: a public Vulkan compute splat renderer (shg8/3DGS.cpp), measured side by side
// with ours before 2026-11-23 (the figures filed with issue 15) on this machine kind (2
// cores, lavapipe 22.3.6), the peer patched only to render headless and to make its radix
// sort correct at subgroup size 8; alternating peer and ours, 3 runs of 1 warm-up + 3
// frames each, median wall ms per frame (the box scene and cameras of ../shared/bench).
// The earlier table here (an older measurement) was 1.4-2x too slow for the peer and
// overstated our lead. 0 = not measured.
constexpr const char* kBaselineLabel =
    "peer shg8/3DGS.cpp, side by side before 2026-11-23 (issue 15), lavapipe 22.3.6, 2 cores";
double baseline_ms(const Config& c) {
  if (c.stereo || c.capture) return 0.0;
  struct B {
    long n;
    std::uint32_t w, h;
    double ms;
  };
  static const B table[] = {{10'000, 320, 180, 33},      {100'000, 640, 360, 376},    {100'000, 1280, 720, 886},
                            {250'000, 1280, 720, 1230}, {500'000, 1280, 720, 1762}, {1'000'000, 1280, 720, 3397}};
  for (const B& b : table)
    if (b.n == c.n && b.w == c.width && b.h == c.height) return b.ms;
  return 0.0;
}

// Process CPU time (all threads, lavapipe's included) in ms: with the machine shared, wall
// time swings with the load while CPU time per frame stays comparable between runs.
// 1-minute load average ("?" when unreadable), printed beside the timings.
std::string load_average() {
  std::ifstream f("/proc/loadavg");
  std::string one;
  return (f >> one) ? one : std::string("?");
}

// $GAUSS_BENCH_DIR, else shared/bench beside the checkout (as the tests find shared/data).
fs::path default_bench_dir() {
  if (const char* env = std::getenv("GAUSS_BENCH_DIR"); env && *env) return env;
  return fs::path(__FILE__).parent_path() / ".." / ".." / ".." / "shared" / "bench";
}

struct RenderBenchOptions {
  std::vector<Config> configs;
  fs::path json_out;
  fs::path bench_dir{default_bench_dir()};
  fs::path verify_box_file;
  fs::path capture;  // capture@WxH rows
  fs::path peer;  // empty: the stored lavapipe baseline column
  int peer_rounds{2};
  int peer_timeout_s{600};
  int frames{5};
  std::string device;
  bool reference{true};
  std::uint32_t ref_rows{0};  // 0 = automatic
  unsigned ref_threads{2};
  render::SplatPassShapes pass_shapes{render::SplatPassShapes::Auto};
};

// Rows of the reference comparison: the whole image when the reference is affordable
// (about 100k Gaussians at 640x360), else a centred band of whole tile rows.
std::pair<std::uint32_t, std::uint32_t> reference_rows(const RenderBenchOptions& o, const Config& c) {
  std::uint32_t rows = o.ref_rows;
  if (rows == 0) {
    const double work = double(c.n) * c.width * c.height * (c.stereo ? 2 : 1);
    rows = work <= 1.0e5 * 640 * 360 * 1.01 ? c.height : 96;
  }
  rows = std::min(rows, c.height);
  std::uint32_t begin = (c.height - rows) / 2 / render::kTileSize * render::kTileSize;
  return {begin, std::min(c.height, begin + rows)};
}

}  // namespace

namespace {

constexpr const char* kDefaultSizes =
    "10k@320x180,100k@640x360,100k@1280x720,250k@1280x720,400k@1280x720,200k@1024x1024:stereo,500k@1280x720,"
    "1M@1280x720";

// Adds the options to `cmd`; the sizes are parsed into o.configs once the command line is.
void add_options(CLI::App& cmd, RenderBenchOptions& o, std::vector<std::string>& sizes) {
  cmd.add_option("--sizes", sizes, "comma-separated sizes: N@WxH or N@WxH:stereo (N with k/M suffixes)")
      ->delimiter(',')
      ->check(CLI::Validator(
          [](std::string& in) -> std::string {
            return parse_config(in) ? std::string{} : "bad size '" + in + "' (want N@WxH, N@WxH:stereo or capture@WxH)";
          },
          ""))
      ->type_name("N@WxH[:stereo]|capture@WxH,...")
      ->default_str(kDefaultSizes);
  cmd.add_option("--frames", o.frames, "measured frames per size after one warm-up frame")
      ->check(gauss::apps::in_range(1, 1000))
      ->type_name("K");
  cmd.add_option("--json", o.json_out, "write the results as JSON")->type_name("FILE");
  cmd.add_option("--device", o.device, "Vulkan device index or name substring (else $GAUSS_DEVICE, else the best)")
      ->type_name("NAME");
  cmd.add_flag_callback("--no-reference", [&o] { o.reference = false; }, "skip the comparison with the CPU reference");
  cmd.add_option("--ref-rows", o.ref_rows, "rows compared with the CPU reference (default: all when cheap, else 96)")
      ->check(gauss::apps::at_least(1u))
      ->type_name("R")
      ->default_str("auto");
  cmd.add_option("--ref-threads", o.ref_threads, "CPU reference blend threads")
      ->check(gauss::apps::in_range(1u, 64u))
      ->type_name("T");
  cmd.add_option("--bench-dir", o.bench_dir, "folder of box_camera_WxH.json (default $GAUSS_BENCH_DIR, else "
                                             "shared/bench beside the checkout)")
      ->type_name("DIR")
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--verify-box", o.verify_box_file,
                 "first check that the in-process box scene equals this output of box_scene.c (N=1000)")
      ->check(CLI::ExistingFile)
      ->type_name("PLY");
  cmd.add_option("--capture", o.capture,
                 "a real capture (any scene file gauss-view reads) for the capture@WxH sizes: placed in front of the "
                 "box camera, rendered at its own SH degree; with --peer the peer gets it too")
      ->check(CLI::ExistingPath)
      ->type_name("FILE");
  cmd.add_option("--peer", o.peer,
                 "run this peer renderer (shg8/3DGS.cpp built with ../shared/gpu/peer/3dgs_bench.patch) on the same "
                 "box scenes, alternating with ours, and print ours/peer per size instead of the stored baseline")
      ->type_name("BIN");
  cmd.add_option("--peer-rounds", o.peer_rounds, "alternating rounds (peer, then ours) per size with --peer")
      ->check(gauss::apps::in_range(1, 20))
      ->type_name("R");
  cmd.add_option_function<std::string>(
         "--shapes",
         [&o](const std::string& v) {
           o.pass_shapes = v == "cpu"   ? render::SplatPassShapes::Cpu
                           : v == "gpu" ? render::SplatPassShapes::Gpu
                                        : render::SplatPassShapes::Auto;
         },
         "compute pass shapes: auto (from the device type, or $GAUSS_PASS_SHAPES), cpu (long per-thread runs, "
         "tuned on lavapipe) or gpu (one element per invocation, subgroup ranks); the images are identical")
      ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
      ->type_name("auto|cpu|gpu")
      ->default_str("auto");
  cmd.add_option("--peer-timeout", o.peer_timeout_s, "seconds one peer run may take with --peer")
      ->check(gauss::apps::in_range(1, 86400))
      ->type_name("S");
}

// Per-pass GPU ms of one frame, summed over the views of the frame.
struct FrameTimes {
  double wall{0}, record{0}, cpu{0}, total{0}, mesh{0}, preprocess{0}, compact{0}, depth_sort{0}, emit{0}, tile_sort{0}, ranges{0},
      blend{0};
  std::uint32_t visible{0}, pairs{0};
  bool overflow{false};
  bool together{false};  // the views' passes were recorded together (view 0's times cover both)
  void add(const render::SplatFrameStats& s) {
    together = together || s.views_together;
    total += s.gpu.total_ms;
    mesh += s.gpu.mesh_ms;
    preprocess += s.gpu.preprocess_ms;
    compact += s.gpu.compact_ms;
    depth_sort += s.gpu.depth_sort_ms;
    emit += s.gpu.emit_ms;
    tile_sort += s.gpu.tile_sort_ms;
    ranges += s.gpu.ranges_ms;
    blend += s.gpu.blend_ms;
    visible += s.visible;
    pairs += s.pairs;
    overflow = overflow || s.pair_overflow;
  }
};

template <class F>
double median_of(const std::vector<FrameTimes>& v, F f) {
  std::vector<double> x;
  for (const auto& t : v) x.push_back(f(t));
  return median(x);
}

// The renderer of one row: the box scene is SH degree 3, a capture its own degree.
render::SplatRendererCreateInfo renderer_info(const RenderBenchOptions& o, const Config& c) {
  return {.capacity = static_cast<std::uint32_t>(std::clamp<long>(c.n, 1, 0xFFFFFFFFl)),
          .sh_degree = c.sh_degree,
          .max_width = c.width,
          .max_height = c.height,
          .pass_shapes = o.pass_shapes};
}

// Measures one row and prints it. `base` is the row's baseline ms (the stored lavapipe table,
// or this round's peer run; 0 = none), shown with the ratio wall_med / base.
int run_config(vk::Context& ctx, const RenderBenchOptions& o, const Config& c, std::span<const Gaussian> scene, double base,
               bool reference, nlohmann::json& out) {
  out = {{"size", c.label}, {"n", c.n}, {"width", c.width}, {"height", c.height}, {"stereo", c.stereo}};
  if (auto plan = render::plan_splat_memory(ctx, renderer_info(o, c)); !plan) {
    std::printf("%-22s skipped: %s\n", c.label.c_str(), plan.message().c_str());
    out["skipped"] = plan.message();
    return 0;
  }
  auto cam = box_camera(o.bench_dir, c.width, c.height);
  if (!cam) {
    std::fprintf(stderr, "gauss-bench render: %s\n", cam.message().c_str());
    return 1;
  }
  const std::uint32_t n = std::uint32_t(c.n);
  auto renderer = render::SplatRenderer::create(ctx, renderer_info(o, c));
  if (!renderer) {
    std::fprintf(stderr, "gauss-bench render: %s: %s\n", c.label.c_str(), renderer.message().c_str());
    return 1;
  }
  auto& r = **renderer;
  if (auto st = r.write_slots(0, scene.first(n)); !st) {
    std::fprintf(stderr, "gauss-bench render: %s\n", st.message().c_str());
    return 1;
  }
  const double ipd = 0.064;
  const Camera left = render::stereo_eye_camera(*cam, ipd, render::Eye::Left);
  const Camera right = render::stereo_eye_camera(*cam, ipd, render::Eye::Right);
  std::vector<FrameTimes> frames;
  const std::array<Camera, 2> eyes{left, right};
  const std::span<const Camera> views = c.stereo ? std::span<const Camera>(eyes) : std::span<const Camera>(&*cam, 1);
  for (int f = 0; f <= o.frames; ++f) {  // frame 0: warm-up, not measured
    FrameTimes t;
    const double cpu0 = process_cpu_ms();
    // render() / render_stereo() in two steps, so that recording + submission (while the
    // GPU waits for it) is timed apart from the wait for the GPU.
    const auto t0 = std::chrono::steady_clock::now();
    auto serial = r.render_frame(views);
    const auto t1 = std::chrono::steady_clock::now();
    auto st = serial ? r.frame_stats(*serial) : Expected<std::array<render::SplatFrameStats, 2>>(serial.error());
    if (!st) {
      std::fprintf(stderr, "gauss-bench render: %s\n", st.message().c_str());
      return 1;
    }
    t.wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    t.record = std::chrono::duration<double, std::milli>(t1 - t0).count();
    t.cpu = process_cpu_ms() - cpu0;
    for (std::size_t v = 0; v < views.size(); ++v) t.add((*st)[v]);
    if (f > 0) frames.push_back(t);
  }
  const FrameTimes& last = frames.back();
  const double wall_med = median_of(frames, [](const FrameTimes& t) { return t.wall; });
  double wall_min = frames[0].wall;
  for (const auto& t : frames) wall_min = std::min(wall_min, t.wall);
  out["frames"] = o.frames;
  out["wall_ms_median"] = wall_med;
  out["wall_ms_min"] = wall_min;
  const double cpu_med = median_of(frames, [](const FrameTimes& t) { return t.cpu; });
  out["process_cpu_ms_median"] = cpu_med;
  const double record_med = median_of(frames, [](const FrameTimes& t) { return t.record; });
  out["record_ms_median"] = record_med;
  out["load_average_1min"] = load_average();
  out["gpu_ms_median"] = {
      {"total", median_of(frames, [](const FrameTimes& t) { return t.total; })},
      {"mesh", median_of(frames, [](const FrameTimes& t) { return t.mesh; })},
      {"preprocess", median_of(frames, [](const FrameTimes& t) { return t.preprocess; })},
      {"compact", median_of(frames, [](const FrameTimes& t) { return t.compact; })},
      {"depth_sort", median_of(frames, [](const FrameTimes& t) { return t.depth_sort; })},
      {"emit", median_of(frames, [](const FrameTimes& t) { return t.emit; })},
      {"tile_sort", median_of(frames, [](const FrameTimes& t) { return t.tile_sort; })},
      {"ranges", median_of(frames, [](const FrameTimes& t) { return t.ranges; })},
      {"blend", median_of(frames, [](const FrameTimes& t) { return t.blend; })}};
  out["visible"] = last.visible;
  out["pairs"] = last.pairs;
  out["pair_overflow"] = last.overflow;
  out["max_pairs"] = r.max_pairs();  // the pairs one view may hold (the memory plan's choice)
  if (c.stereo) out["views_together"] = last.together;

  // CRC-32 of each view's last image: a renderer change that must leave the images
  // byte-identical is checked by comparing this column before and after.
  std::string digest;
  for (int v = 0; v < (c.stereo ? 2 : 1); ++v) {
    auto image = r.read_image(std::uint32_t(v));
    if (!image) {
      std::fprintf(stderr, "gauss-bench render: %s\n", image.message().c_str());
      return 1;
    }
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), image->pixels.data(), uInt(image->pixels.size()));
    char hex[16];
    std::snprintf(hex, sizeof hex, "%08lx", static_cast<unsigned long>(crc));
    digest += (v ? "/" : "") + std::string(hex);
  }
  out["image_crc32"] = digest;

  std::string err_text = "reference skipped";
  if (reference) {
    const auto [row_begin, row_end] = reference_rows(o, c);
    double worst_psnr = std::numeric_limits<double>::infinity(), ref_ms = 0.0;
    int worst_err = 0;
    std::uint64_t ref_pairs = 0;
    for (int v = 0; v < (c.stereo ? 2 : 1); ++v) {
      auto gpu_image = r.read_image(std::uint32_t(v));
      if (!gpu_image) {
        std::fprintf(stderr, "gauss-bench render: %s\n", gpu_image.message().c_str());
        return 1;
      }
      render::ReferenceOptions ro;
      ro.row_begin = row_begin;
      ro.row_end = row_end;
      ro.threads = o.ref_threads;
      const auto t0 = std::chrono::steady_clock::now();
      auto ref = render::render_reference(scene.first(n), {}, c.sh_degree, c.stereo ? (v == 0 ? left : right) : *cam, ro);
      ref_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!ref) {
        std::fprintf(stderr, "gauss-bench render: %s\n", ref.message().c_str());
        return 1;
      }
      auto d = render::compare_images(ref->rgba8, *gpu_image, row_begin, row_end);
      if (!d) {
        std::fprintf(stderr, "gauss-bench render: %s\n", d.message().c_str());
        return 1;
      }
      worst_psnr = std::min(worst_psnr, d->psnr_db);
      worst_err = std::max(worst_err, d->max_abs_error);
      ref_pairs += ref->stats.tile_pairs;
    }
    out["reference"] = {{"rows", {row_begin, row_end}},
                        {"psnr_db", std::isinf(worst_psnr) ? nlohmann::json("inf") : nlohmann::json(worst_psnr)},
                        {"max_abs_error", worst_err},
                        {"cpu_ms", ref_ms},
                        {"reference_pairs", ref_pairs}};
    char buf[96];
    std::snprintf(buf, sizeof buf, "%6.1f dB max %d/255 rows %u-%u%s, ref %.0f ms", std::isinf(worst_psnr) ? 999.0 : worst_psnr,
                  worst_err, row_begin, row_end, row_end - row_begin < c.height ? " (subset)" : "", ref_ms);
    err_text = buf;
  }
  const double gpu_total = out["gpu_ms_median"]["total"];
  const double sort_ms = double(out["gpu_ms_median"]["depth_sort"]) + double(out["gpu_ms_median"]["tile_sort"]);
  const double blend_ms = out["gpu_ms_median"]["blend"];
  char ratio[32] = "    -";
  if (base > 0) std::snprintf(ratio, sizeof ratio, "%5.2f", wall_med / base);
  std::printf("%-22s %8.2f %8.2f %8.2f %8.2f %5s %8.2f %8.2f %8.2f %8.2f %9u %10u %7.0f %s %17s | %s%s\n",
              c.label.c_str(), wall_med, wall_min, record_med, cpu_med, load_average().c_str(), gpu_total,
              double(out["gpu_ms_median"]["preprocess"]), sort_ms, blend_ms, last.visible, last.pairs, base, ratio,
              digest.c_str(), err_text.c_str(), last.overflow ? " PAIR OVERFLOW" : "");
  std::fflush(stdout);
  return 0;
}

// One size against the peer: o.peer_rounds rounds, each the peer on the box scene PLY then
// ours (alternating, so a change in the machine's load falls on both), each round printed as
// a row whose base_ms is that round's peer run. An error means the peer gave no time: that
// ends the run, since a table with holes would read as a comparison. Else the value is our
// rows' exit code. Stereo sizes have no peer (it renders one view): ours runs once.
Expected<int> run_config_with_peer(vk::Context& ctx, const RenderBenchOptions& o, const Config& c, std::span<const Gaussian> scene,
                                   const fs::path& work_dir, nlohmann::json& results, PeerRow& summary) {
  summary.size = c.label;
  int rc = 0;
  if (c.stereo) {
    nlohmann::json row;
    rc = run_config(ctx, o, c, scene, 0.0, o.reference, row);
    summary.ours_ms = row.value("wall_ms_median", 0.0);
    summary.note = "no peer figure: the peer renders one view";
    results.push_back(row);
    return rc;
  }
  auto cam = box_camera(o.bench_dir, c.width, c.height);
  if (!cam) return Error{cam.message()};
  const fs::path ply = work_dir / (c.capture ? "capture.ply" : "box" + std::to_string(c.n) + ".ply");
  if (auto st = c.capture ? write_peer_capture_ply(ply, scene) : write_box_ply(ply, c.n); !st)
    return Error{st.message()};
  std::vector<double> peer_ms, ours_ms;
  for (int round = 1; round <= o.peer_rounds; ++round) {
    auto p = run_peer({.binary = o.peer,
                       .scene = ply,
                       .width = c.width,
                       .height = c.height,
                       .fov_deg = horizontal_fov_deg(cam->width, cam->fx),
                       .frames = o.frames,
                       .timeout_s = o.peer_timeout_s});
    if (!p) return Error{c.label + ", round " + std::to_string(round) + ": " + p.message()};
    peer_ms.push_back(*p);
    nlohmann::json row;
    if (run_config(ctx, o, c, scene, *p, o.reference && round == 1, row) != 0) {
      rc = 1;
      row["error"] = true;
    }
    row["round"] = round;
    row["peer_wall_ms"] = *p;
    if (row.contains("wall_ms_median")) {
      ours_ms.push_back(row["wall_ms_median"]);
      row["wall_vs_peer"] = ours_ms.back() / *p;
    }
    results.push_back(row);
  }
  std::error_code ec;
  fs::remove(ply, ec);
  summary.peer_ms = median(peer_ms);
  summary.ours_ms = median(ours_ms);
  if (ours_ms.empty()) summary.note = "ours skipped (see its rows)";
  return rc;
}

}  // namespace

int bench_render_main(const RenderBenchOptions& o) {
  if (!o.verify_box_file.empty() && !verify_box(o.verify_box_file)) return 1;
  if (!o.peer.empty()) {
    if (auto st = check_peer_binary(o.peer); !st) {
      std::fprintf(stderr, "gauss-bench render: --peer: %s\n", st.message().c_str());
      return 1;
    }
  }
  auto ctx = vk::Context::create({.app_name = "gauss-bench render", .device_override = o.device});
  if (!ctx) {
    std::fprintf(stderr, "gauss-bench render: no usable Vulkan device: %s\n", ctx.message().c_str());
    return 1;
  }
  auto shapes = render::choose_pass_shapes(**ctx, o.pass_shapes);
  if (!shapes) {
    std::fprintf(stderr, "gauss-bench render: %s\n", shapes.message().c_str());
    return 1;
  }
  // capture@WxH rows: the file once; its size and degree into those rows.
  std::vector<Config> configs = o.configs;
  std::optional<LoadedScene> capture;
  for (Config& c : configs) {
    if (!c.capture) continue;
    if (o.capture.empty()) {
      std::fprintf(stderr, "gauss-bench render: %s needs --capture FILE\n", c.label.c_str());
      return 1;
    }
    if (!capture) {
      auto loaded = load_scene_file(o.capture, std::nullopt);
      if (!loaded) {
        std::fprintf(stderr, "gauss-bench render: --capture: %s\n", loaded.message().c_str());
        return 1;
      }
      capture = std::move(*loaded);
    }
    c.n = long(capture->scene.cloud.gaussians.size());
    c.sh_degree = capture->scene.cloud.sh_degree;
  }
  long max_n = 0;
  for (const Config& c : configs)
    if (!c.capture && render::plan_splat_memory(**ctx, renderer_info(o, c)).ok()) max_n = std::max(max_n, c.n);
  // The box scene for N is the first N Gaussians of the scene for any larger N.
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<Gaussian> scene = box_gaussians(max_n);
  const double gen_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const std::string base_label =
      o.peer.empty() ? std::string(kBaselineLabel)
                     : "this round's run of the peer " + o.peer.string() + ", just before ours, same scene and camera";
  std::printf("gauss-bench render | device %s | box scene SH3, %ld Gaussians generated in %.0f ms | %d frames after "
              "1 warm-up\nwall = render call incl. submit + wait (no readback); record = its recording + submission part; "
              "cpu = process CPU time "
              "(all lavapipe threads) per frame; load = 1-min load average;\ngpu = timestamps; all medians; stereo rows "
              "sum both eyes; image crc32 = last frame's pixels (left/right); ratio = wall_med / base_ms (base_ms: %s); "
              "times taken on a shared machine (under load)\n\n",
              (*ctx)->device_name().c_str(), max_n, gen_ms, o.frames, base_label.c_str());
  std::printf("pass shapes: %s; %s\n\n", shapes->reason.c_str(), shapes->views_reason.c_str());
  std::printf("%-22s %8s %8s %8s %8s %5s %8s %8s %8s %8s %9s %10s %7s %5s %17s | %s\n", "size", "wall_med", "wall_min",
              "record", "cpu_med", "load", "gpu_tot", "preproc", "sorts", "blend", "visible", "pairs", "base_ms", "ratio",
              "image crc32", "vs CPU reference (PSNR, max err)");
  nlohmann::json results = nlohmann::json::array();
  std::vector<PeerRow> peer_rows;
  std::optional<PeerWorkDir> work_dir;
  if (!o.peer.empty()) work_dir.emplace();
  int rc = 0;
  for (const Config& c : configs) {
    // A capture row's scene: the capture placed in front of this row's camera.
    std::vector<Gaussian> placed_capture;
    if (c.capture) {
      auto cam = box_camera(o.bench_dir, c.width, c.height);
      if (!cam) {
        std::fprintf(stderr, "gauss-bench render: %s\n", cam.message().c_str());
        return 1;
      }
      BenchCapture placed = place_capture(*capture, *cam);
      std::printf("%s: %s, %s\n", c.label.c_str(), o.capture.string().c_str(), placed.placement.c_str());
      placed_capture = std::move(placed.gaussians);
    }
    const std::span<const Gaussian> row_scene =
        c.capture ? std::span<const Gaussian>(placed_capture) : std::span<const Gaussian>(scene);
    if (work_dir) {
      PeerRow summary;
      auto st = run_config_with_peer(**ctx, o, c, row_scene, work_dir->path, results, summary);
      if (!st) {
        std::fflush(stdout);
        std::fprintf(stderr, "gauss-bench render: --peer %s gave no time: %s\n", o.peer.string().c_str(),
                     st.message().c_str());
        return 1;
      }
      rc = std::max(rc, *st);
      peer_rows.push_back(summary);
      continue;
    }
    nlohmann::json row;
    const double base = baseline_ms(c);
    if (run_config(**ctx, o, c, row_scene, base, o.reference, row) != 0) {
      rc = 1;
      row["error"] = true;
    }
    if (c.capture) row["capture"] = o.capture.string();
    if (base > 0) {
      row["baseline_wall_ms"] = base;
      row["baseline"] = kBaselineLabel;
      if (row.contains("wall_ms_median")) row["wall_vs_baseline"] = double(row["wall_ms_median"]) / base;
    }
    results.push_back(row);
  }
  if (work_dir) print_peer_summary(peer_rows, o.peer, o.peer_rounds, o.frames);
  if (!o.json_out.empty()) {
    nlohmann::json doc = {{"bench", "render"},
                          {"device", (*ctx)->device_name()},
                          {"pass_shapes", render::pass_shapes_name(shapes->shapes)},
                          {"pass_shapes_reason", shapes->reason},
                          {"views_together", shapes->views_together},
                          {"views_reason", shapes->views_reason},
                          {"frames", o.frames},
                          {"note", "wall and gpu ms are medians over the measured frames on a shared, loaded machine"},
                          {"results", results}};
    if (work_dir) doc["peer"] = peer_summary_json(peer_rows, o.peer, o.peer_rounds);
    if (!write_json(o.json_out, doc, "render")) return 1;
  }
  return rc;
}

namespace {

BenchRun bench_render_setup(CLI::App& cmd) {
  struct State {
    RenderBenchOptions o;
    std::vector<std::string> sizes;
  };
  auto st = std::make_shared<State>();
  add_options(cmd, st->o, st->sizes);
  return [st] {
    if (st->sizes.empty()) st->sizes = CLI::detail::split(kDefaultSizes, ',');
    for (const std::string& item : st->sizes) st->o.configs.push_back(*parse_config(item));  // checked by the option
    return bench_render_main(st->o);
  };
}

}  // namespace

GAUSS_BENCH("render", "splat renderer on the box scene: GPU ms per pass, wall ms, PSNR vs the CPU reference",
            bench_render_setup);
