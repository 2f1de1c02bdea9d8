// gauss-bench upload: the staged uploads' two ways of applying a frame's writes, timed on
// the GPU: R scattered regions of one slot record each (64 bytes) as vkCmdCopyBuffer
// regions, against the same regions as one compute scatter (upload_scatter.comp). The
// region count at which the scatter starts to win is what
// StagedUploadsCreateInfo::scatter_min_regions should be on this device. Each row checks
// the destination against a CPU model after its frames (wrong bytes are printed beside
// the times, as every bench here does).
//
//   gauss-bench upload [--device NAME] [--frames N] [--regions R,R,...] [--json PATH]
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss_cli.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"
#include "gauss/render/vk_timestamps.h"

namespace {

using namespace gauss::bench;
namespace vk = gauss::vk;

struct UploadBenchOptions {
  std::string device;
  int frames{20};
  std::vector<std::uint32_t> regions{1, 4, 8, 16, 32, 64, 128, 512, 2048, 8192};
  std::string json_path;
};

constexpr VkDeviceSize kRecord = 64;          // one slot's core record
constexpr VkDeviceSize kTarget = 64ull << 20;  // a 1M-slot core buffer

struct UploadRow {
  double gpu_ms{0}, record_ms{0};
  std::uint64_t copy_regions{0}, scatter_regions{0}, wrong_bytes{0};
};

// `frames` frames of R writes at distinct random record positions of `dst` (never
// adjacent: one region each), GPU time of the upload pass per frame, then the check.
gauss::Expected<UploadRow> time_uploads(vk::Context& ctx, std::uint32_t scatter_min, std::uint32_t r, int frames,
                                  std::uint64_t seed) {
  auto ring = vk::FrameRing::create(ctx, 1);
  if (!ring) return ring.error();
  auto up = vk::StagedUploads::create(ctx, **ring, {.initial_bytes = 8u << 20, .scatter_min_regions = scatter_min});
  if (!up) return up.error();
  auto dst = vk::Buffer::create(ctx, {.size = kTarget, .name = "upload bench target"});
  auto q = vk::TimestampQueries::create(ctx, 2);
  if (!dst || !q) return !dst ? dst.error() : q.error();
  std::vector<std::uint8_t> model(kTarget, 0);
  if (auto st = dst->upload(model.data(), kTarget); !st) return st.error();
  std::mt19937_64 rng{seed};  // raw output only: the same on every platform
  const std::uint64_t records = kTarget / kRecord;
  std::vector<double> gpu, rec;
  std::vector<std::uint64_t> picked;
  std::uint8_t bytes[kRecord];
  for (int f = 0; f <= frames; ++f) {  // frame 0: pipeline warm-up, not timed
    // Every other record: distinct and never adjacent, so each write is its own region.
    picked.clear();
    while (picked.size() < r) picked.push_back(2 * (rng() % (records / 2)));
    std::sort(picked.begin(), picked.end());
    picked.erase(std::unique(picked.begin(), picked.end()), picked.end());
    for (std::uint64_t rec_index : picked) {
      for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
      const VkDeviceSize at = rec_index * kRecord;
      if (auto st = (*up)->write(*dst, at, bytes, kRecord); !st) return st.error();
      std::memcpy(model.data() + at, bytes, kRecord);
    }
    auto frame = (*ring)->begin();
    if (!frame) return frame.error();
    const auto t0 = Clock::now();
    q->reset(frame->cmd);
    q->write(frame->cmd, 0);
    (*up)->record(frame->cmd);
    q->write(frame->cmd, 1);
    const double record_ms = ms_since(t0);
    if (auto st = (*ring)->submit(); !st) return st.error();
    (*up)->submitted();
    if (auto st = (*ring)->wait_all(); !st) return st.error();
    auto ns = q->elapsed_ns(0, 1);
    if (!ns) return ns.error();
    if (f > 0) {
      gpu.push_back(*ns * 1e-6);
      rec.push_back(record_ms);
    }
  }
  std::vector<std::uint8_t> back(kTarget);
  if (auto st = dst->download(back.data(), kTarget); !st) return st.error();
  UploadRow row;
  for (VkDeviceSize i = 0; i < kTarget; ++i) row.wrong_bytes += back[i] != model[i] ? 1 : 0;
  row.gpu_ms = median(gpu);
  row.record_ms = median(rec);
  row.copy_regions = (*up)->stats().copy_regions;
  row.scatter_regions = (*up)->stats().scatter_regions;
  return row;
}

int run_upload(const UploadBenchOptions& o) {
  auto ctx = vk::Context::create({.app_name = "bench-upload", .device_override = o.device});
  if (!ctx) {
    std::fprintf(stderr, "gauss-bench upload: %s\n", ctx.message().c_str());
    return 1;
  }
  std::printf("device: %s; %d frames per row after a warm-up, medians; R regions of %llu bytes at random\n"
              "positions of a %llu MiB buffer; gpu = timestamps around the upload pass; record = its CPU recording\n"
              "(scatter: the piece table is built then); this device's default scatter threshold: %u regions\n\n",
              (*ctx)->device_name().c_str(), o.frames, static_cast<unsigned long long>(kRecord),
              static_cast<unsigned long long>(kTarget >> 20), vk::device_scatter_min_regions(**ctx));
  std::printf("%8s %12s %12s %12s %12s %10s %12s\n", "regions", "copy gpu ms", "scat gpu ms", "copy/scat",
              "copy rec ms", "scat rec ms", "wrong bytes");
  nlohmann::json rows = nlohmann::json::array();
  std::uint32_t crossover = 0;
  for (std::uint32_t r : o.regions) {
    auto copies = time_uploads(**ctx, std::numeric_limits<std::uint32_t>::max(), r, o.frames, 1000 + r);
    auto scatter = copies ? time_uploads(**ctx, 0, r, o.frames, 1000 + r) : copies;
    if (!copies || !scatter) {
      std::fprintf(stderr, "gauss-bench upload: %s\n", (!copies ? copies : scatter).message().c_str());
      return 1;
    }
    if (copies->scatter_regions != 0 || scatter->copy_regions != 0) {
      std::fprintf(stderr, "gauss-bench upload: %u regions did not take the path asked for\n", r);
      return 1;
    }
    const double ratio = scatter->gpu_ms > 0 ? copies->gpu_ms / scatter->gpu_ms : 0.0;
    if (crossover == 0 && ratio > 1.0) crossover = r;
    std::printf("%8u %12.4f %12.4f %12.2f %12.4f %10.4f %12llu\n", r, copies->gpu_ms, scatter->gpu_ms, ratio,
                copies->record_ms, scatter->record_ms,
                static_cast<unsigned long long>(copies->wrong_bytes + scatter->wrong_bytes));
    rows.push_back({{"regions", r},
                    {"copy_gpu_ms", copies->gpu_ms},
                    {"scatter_gpu_ms", scatter->gpu_ms},
                    {"copy_record_ms", copies->record_ms},
                    {"scatter_record_ms", scatter->record_ms},
                    {"wrong_bytes", copies->wrong_bytes + scatter->wrong_bytes}});
  }
  if (crossover) std::printf("\nthe scatter is faster on the GPU from %u regions on (of those measured)\n", crossover);
  else std::printf("\nthe scatter was never faster on the GPU here\n");
  nlohmann::json out = {{"device", (*ctx)->device_name()},
                        {"frames", o.frames},
                        {"record_bytes", kRecord},
                        {"device_scatter_min_regions", vk::device_scatter_min_regions(**ctx)},
                        {"first_faster_scatter_regions", crossover},
                        {"rows", rows}};
  if (!o.json_path.empty() && !write_json(o.json_path, out, "upload")) return 1;
  return 0;
}

BenchRun bench_upload_setup(CLI::App& cmd) {
  auto o = std::make_shared<UploadBenchOptions>();
  cmd.add_option("--device", o->device, "Vulkan device index or name substring (else $GAUSS_DEVICE, else the best)")
      ->type_name("NAME");
  cmd.add_option("--frames", o->frames, "timed frames per row")->check(gauss::apps::at_least(1))->type_name("N");
  cmd.add_option("--regions", o->regions, "region counts, comma-separated")
      ->delimiter(',')
      ->check(gauss::apps::in_range<std::uint32_t>(1, 100000))
      ->type_name("R,R,...");
  cmd.add_option("--json", o->json_path, "write the results as JSON")->type_name("PATH");
  return [o] { return run_upload(*o); };
}

}  // namespace

GAUSS_BENCH("upload", "staged uploads: GPU ms of R scattered regions as copies vs one compute scatter",
            bench_upload_setup);
