// gauss-fuse: fuses an RGB-D folder (3DMatch/SUN3D, TUM or Replica layout) into the TSDF
// and writes the surface mesh as a PLY, so a user can inspect the surface clients will get.
//
// Options in options.cpp (--help lists them). A progress bar on stderr while frames fuse
// (on a terminal; in a log one line when done), one summary on stdout at the end.
//
// Exit status: 0 written; 1 the folder, a frame (without --skip-bad), the fusion or the
// output failed, the message naming the frame or file; 2 bad arguments.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <glm/common.hpp>

#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/tsdf.h"
#include "gauss_cli.h"
#include "options.h"

namespace {

using namespace gauss;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// "[########------------]  7/20 frames  3.1 s  <name>"
std::string progress_text(std::size_t done, std::size_t total, double elapsed_s, const std::string& name) {
  constexpr int kWidth = 24;
  const int filled = total == 0 ? kWidth : int(double(done) / double(total) * kWidth);
  std::string bar(std::size_t(filled), '#');
  bar.resize(kWidth, '-');
  char text[96];
  std::snprintf(text, sizeof text, "[%s] %zu/%zu frames  %.1f s  ", bar.c_str(), done, total, elapsed_s);
  // Keep the line short enough for a terminal: the end of a long path says the most.
  std::string shown = name.size() > 48 ? "..." + name.substr(name.size() - 45) : name;
  return text + shown;
}

int fail(const std::string& message) {
  std::fprintf(stderr, "gauss-fuse: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  fuse_app::Options o;
  if (auto rc = fuse_app::parse_options(argc, argv, o)) return *rc;
  const auto t_start = Clock::now();

  auto src = RgbdFolderSource::open(o.rgbd);
  if (!src) return fail(src.message());
  std::vector<std::size_t> selected;
  for (std::size_t i = o.first; i < src->frame_count() && (o.frames == 0 || selected.size() < o.frames); i += o.stride)
    selected.push_back(i);
  if (selected.empty()) {
    std::fprintf(stderr, "--first: %zu is past the last frame (%s lists %zu)\nRun with --help for more information.\n",
                 o.first, o.rgbd.c_str(), src->frame_count());
    return apps::kUsageError;
  }

  TsdfConfig cfg;
  cfg.voxel_size = o.voxel_size;
  cfg.truncation = o.truncation;
  cfg.min_depth = o.min_depth;
  cfg.max_depth = o.max_depth;
  cfg.max_blocks = o.max_blocks;
  auto vol = TsdfVolume::create(cfg);
  if (!vol) {
    std::fprintf(stderr, "%s\nRun with --help for more information.\n", vol.message().c_str());
    return apps::kUsageError;
  }
  const double truncation = o.truncation > 0.0f ? o.truncation : 3.0 * o.voxel_size;
  std::printf("gauss-fuse: %s: %s layout, %zu frames listed, fusing %zu (first %zu, stride %zu)\n", o.rgbd.c_str(),
              rgbd_layout_name(src->layout()), src->frame_count(), selected.size(), o.first, o.stride);
  std::fflush(stdout);

  // Fuse, frame by frame.
  const auto t_fuse = Clock::now();
  double load_s = 0.0, integrate_s = 0.0;
  std::size_t fused = 0, skipped = 0;
  {
    apps::StatusLine line;
    for (std::size_t k = 0; k < selected.size(); ++k) {
      const std::size_t i = selected[k];
      line.update(progress_text(k, selected.size(), seconds_since(t_fuse), src->frame_name(i)), k == 0);
      const auto t0 = Clock::now();
      auto frame = src->load(i, Epoch(k + 1));
      load_s += seconds_since(t0);
      Status st = Ok{};
      if (frame) {
        const auto t1 = Clock::now();
        st = vol->integrate(*frame);
        integrate_s += seconds_since(t1);
      } else {
        st = frame.error();
      }
      if (st) {
        ++fused;
        continue;
      }
      line.done({});
      if (!o.skip_bad) return fail(st.message() + "\n(--skip-bad skips frames that cannot be used)");
      std::fprintf(stderr, "gauss-fuse: skipped: %s\n", st.message().c_str());
      ++skipped;
    }
    line.done(progress_text(selected.size(), selected.size(), seconds_since(t_fuse), "done"));
  }
  if (fused == 0) return fail("no frame of " + o.rgbd.string() + " could be fused (all " +
                              std::to_string(skipped) + " were skipped)");

  // Extract and write.
  const auto t_extract = Clock::now();
  const TriangleMesh mesh = apps::with_elapsed_status("extracting the surface", [&] { return vol->extract_all(); });
  const double extract_s = seconds_since(t_extract);
  if (mesh.indices.empty())
    return fail("the fused surface of " + o.rgbd.string() +
                " is empty: no depth within --min-depth..--max-depth, or the poses never see one surface");
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const auto t_write = Clock::now();
  PlyMeshWriteOptions wo;
  wo.format = o.ascii ? PlyFormat::Ascii : PlyFormat::BinaryLittleEndian;
  const Status written =
      apps::with_elapsed_status("writing " + o.out.string(), [&] { return write_mesh_ply(o.out, mesh, wo); });
  if (!written) return fail(written.message());
  const double write_s = seconds_since(t_write);
  std::error_code ec;
  const auto out_bytes = std::filesystem::file_size(o.out, ec);

  const TsdfStats stats = vol->stats();
  std::printf("frames     %zu fused, %zu skipped, of %zu listed\n", fused, skipped, src->frame_count());
  std::printf("volume     %zu blocks = %zu voxels (%.1f MiB); voxel %.3g m, truncation %.3g m, depth %.3g..%.3g m\n",
              stats.blocks, stats.blocks * 512, double(stats.bytes) / (1024.0 * 1024.0), double(o.voxel_size),
              truncation, double(o.min_depth), double(o.max_depth));
  std::printf("mesh       %zu vertices, %zu triangles\n", mesh.positions.size(), mesh.indices.size() / 3);
  std::printf("bounds     min (%.3f, %.3f, %.3f) max (%.3f, %.3f, %.3f) m, size %.3f x %.3f x %.3f m\n",
              double(lo.x), double(lo.y), double(lo.z), double(hi.x), double(hi.y), double(hi.z), double(hi.x - lo.x),
              double(hi.y - lo.y), double(hi.z - lo.z));
  std::printf("time       %.2f s: load %.2f s, integrate %.2f s, extract %.2f s, write %.2f s\n",
              seconds_since(t_start), load_s, integrate_s, extract_s, write_s);
  std::printf("wrote      %s (%.1f MiB, %s)\n", o.out.c_str(), ec ? 0.0 : double(out_bytes) / (1024.0 * 1024.0),
              o.ascii ? "ascii" : "binary little endian");
  return 0;
}
