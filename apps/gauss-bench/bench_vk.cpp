// gauss-bench vk: costs of the Vulkan core on this device: context creation (with and
// without validation), a 1024x1024 compute dispatch (the test pattern shader, GPU
// timestamps), host->buffer upload throughput (Buffer::upload) and GPU buffer copy
// throughput. Each figure is printed beside its check (bytes that came back wrong,
// pattern pixels that differ between runs), as every bench here does.
//
//   gauss-bench vk [--device NAME] [--repeat N] [--json PATH]
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss_cli.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"
#include "gauss/render/vk_timestamps.h"
#include "gauss/shaders/test_pattern.comp.spv.h"
#include "test_pattern_layout.h"

namespace {

using namespace gauss::bench;


struct VkBenchOptions {
  std::string device;  // Vulkan device index or name substring
  int repeat{5};       // timed repetitions after the cold first one
  std::string json_path;
};

int run_vk(const VkBenchOptions& o) {
  const std::string& device = o.device;
  const int repeat = o.repeat;
  const std::string& json_path = o.json_path;
  nlohmann::json out;

  // Context creation, cold first (driver JIT/caches), then the median of the rest.
  for (bool validation : {false, true}) {
    std::vector<double> times;
    for (int r = 0; r < repeat + 1; ++r) {
      const auto t0 = Clock::now();
      auto ctx = gauss::vk::Context::create({.app_name = "bench-vk", .device_override = device, .enable_validation = validation});
      const double ms = ms_since(t0);
      if (!ctx) {
        std::fprintf(stderr, "gauss-bench vk: %s\n", ctx.message().c_str());
        return 1;
      }
      times.push_back(ms);
    }
    const double first = times.front();
    times.erase(times.begin());
    const char* key = validation ? "context_create_validation_ms" : "context_create_ms";
    out[key] = {{"first", first}, {"median", median(times)}};
  }

  auto ctx_or = gauss::vk::Context::create({.app_name = "bench-vk", .device_override = device});
  if (!ctx_or) {
    std::fprintf(stderr, "gauss-bench vk: %s\n", ctx_or.message().c_str());
    return 1;
  }
  gauss::vk::Context& ctx = **ctx_or;
  out["device"] = ctx.device_name();
  out["subgroup_size"] = ctx.subgroup_size();

  // 1024x1024 dispatch of the test pattern into the offscreen colour target.
  constexpr std::uint32_t kSize = 1024;
  const std::uint32_t groups = kSize / gauss::gpu::TEST_PATTERN_WORKGROUP;
  auto target = gauss::vk::OffscreenTarget::create(ctx, kSize, kSize, "bench");
  auto sums = gauss::vk::Buffer::create(ctx, {.size = groups * groups * 4, .name = "sums"});
  auto pipeline = gauss::vk::ComputePipeline::create(
      ctx, {.name = "pattern",
            .shader = gauss::vk::spirv(gauss_spv_test_pattern_comp),
            .bindings = {{gauss::gpu::TEST_PATTERN_BINDING_IMAGE, gauss::vk::DescriptorKind::StorageImage},
                         {gauss::gpu::TEST_PATTERN_BINDING_TILE_SUMS, gauss::vk::DescriptorKind::StorageBuffer}},
            .push_constant_size = sizeof(gauss::gpu::TestPatternPush),
            .spec_constants = {{gauss::gpu::TEST_PATTERN_SPEC_R_MUL, 7}}});
  auto queries = gauss::vk::TimestampQueries::create(ctx, 2);
  if (!target || !sums || !pipeline || !queries) {
    std::fprintf(stderr, "gauss-bench vk: setup failed: %s\n",
                 !target ? target.message().c_str() : !sums ? sums.message().c_str()
                 : !pipeline ? pipeline.message().c_str() : queries.message().c_str());
    return 1;
  }
  std::vector<double> gpu_ms, wall_ms;
  std::size_t differing_runs = 0;
  gauss::ImageRGBA8 first_image;
  for (int r = 0; r < repeat + 1; ++r) {
    gauss::Status bound = gauss::Ok{};
    const auto t0 = Clock::now();
    auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
      queries->reset(cmd);
      target->color().transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
      bound = pipeline->bind(cmd, {{0, &target->color()}, {1, &*sums}});
      pipeline->push_constants(cmd, gauss::gpu::TestPatternPush{kSize, kSize, 12345, 0});
      queries->write(cmd, 0);
      vkCmdDispatch(cmd, groups, groups, 1);
      queries->write(cmd, 1);
    });
    const double wall = ms_since(t0);
    if (!st || !bound) {
      std::fprintf(stderr, "gauss-bench vk: dispatch failed: %s\n", !st ? st.message().c_str() : bound.message().c_str());
      return 1;
    }
    auto ns = queries->elapsed_ns(0, 1);
    auto img = target->read_color(ctx);
    if (!ns || !img) {
      std::fprintf(stderr, "gauss-bench vk: readback failed\n");
      return 1;
    }
    if (r == 0) {
      first_image = *img;  // run 0 includes pipeline warm-up: not timed
      continue;
    }
    if (img->pixels != first_image.pixels) ++differing_runs;
    gpu_ms.push_back(*ns * 1e-6);
    wall_ms.push_back(wall);
  }
  out["dispatch_1024"] = {{"gpu_ms_median", median(gpu_ms)},
                          {"submit_wait_ms_median", median(wall_ms)},
                          {"runs_differing_from_first", differing_runs}};

  // The fixed cost of one small dispatch (one workgroup) in a chain of kChain: with a
  // compute->compute barrier after each (what every pass of the splat renderer pays),
  // without, and indirect with its arguments in device-local or in host-visible memory.
  // On a CPU device this is mostly recording; on a GPU it is what many small passes cost.
  constexpr int kChain = 64;
  struct ChainCase {
    const char* name;
    bool barrier;
    int indirect;  // 0 direct, 1 arguments in device-local memory, 2 in host-visible memory
  };
  const ChainCase chain_cases[] = {{"direct, barrier after each", true, 0},
                                   {"direct, no barriers", false, 0},
                                   {"indirect (device-local args), barrier", true, 1},
                                   {"indirect (host-visible args), barrier", true, 2}};
  auto args_dev = gauss::vk::Buffer::create(ctx, {.size = 16, .usage = VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
                                                  .memory = gauss::vk::MemoryUsage::DeviceLocal, .name = "args dev"});
  auto args_host = gauss::vk::Buffer::create(ctx, {.size = 16, .usage = VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
                                                   .memory = gauss::vk::MemoryUsage::HostVisible, .name = "args host"});
  const std::uint32_t one_group[4] = {1, 1, 1, 0};
  if (!args_dev || !args_host || !args_dev->upload(one_group, 16) || !args_host->upload(one_group, 16)) {
    std::fprintf(stderr, "gauss-bench vk: indirect argument buffers failed\n");
    return 1;
  }
  nlohmann::json chains = nlohmann::json::array();
  for (const ChainCase& cc : chain_cases) {
    std::vector<double> per_dispatch_us;
    for (int r = 0; r < repeat + 1; ++r) {
      gauss::Status bound = gauss::Ok{};
      auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
        queries->reset(cmd);
        target->color().transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
        bound = pipeline->bind(cmd, {{0, &target->color()}, {1, &*sums}});
        pipeline->push_constants(cmd, gauss::gpu::TestPatternPush{8, 8, 1, 0});
        queries->write(cmd, 0);
        for (int i = 0; i < kChain; ++i) {
          if (cc.indirect == 0) vkCmdDispatch(cmd, 1, 1, 1);
          else vkCmdDispatchIndirect(cmd, (cc.indirect == 1 ? *args_dev : *args_host).handle(), 0);
          if (cc.barrier) gauss::vk::compute_to_compute_barrier(cmd);
        }
        queries->write(cmd, 1);
      });
      auto ns = queries->elapsed_ns(0, 1);
      if (!st || !bound || !ns) {
        std::fprintf(stderr, "gauss-bench vk: dispatch chain failed\n");
        return 1;
      }
      if (r > 0) per_dispatch_us.push_back(*ns * 1e-3 / kChain);
    }
    chains.push_back({{"case", cc.name}, {"us_per_dispatch_median", median(per_dispatch_us)}});
  }
  out["dispatch_chain"] = {{"dispatches", kChain}, {"cases", chains}};

  // Upload throughput through Buffer::upload (memcpy when mapped, staging otherwise),
  // and GPU-side buffer->buffer copy throughput.
  nlohmann::json uploads = nlohmann::json::array();
  // Staged cases force the staging path (never_map) that a discrete GPU takes.
  struct UploadCase {
    bool staged;
    std::size_t mib;
  };
  const UploadCase cases[] = {{false, 1}, {false, 16}, {false, 64}, {true, 1}, {true, 16}, {true, 64}};
  for (const UploadCase& uc : cases) {
    const bool staged = uc.staged;
    const std::size_t mib = uc.mib;
    const std::size_t bytes = mib << 20;
    std::vector<std::uint8_t> data(bytes);
    for (std::size_t i = 0; i < bytes; ++i) data[i] = static_cast<std::uint8_t>(i * 2654435761u >> 13);
    auto a = gauss::vk::Buffer::create(ctx, {.size = bytes, .name = "upload", .never_map = staged});
    auto b = gauss::vk::Buffer::create(ctx, {.size = bytes, .name = "copy dst"});
    auto q = gauss::vk::TimestampQueries::create(ctx, 2);
    if (!a || !b || !q) {
      std::fprintf(stderr, "gauss-bench vk: buffer setup failed for %zu MiB\n", mib);
      return 1;
    }
    std::vector<double> up_ms, copy_ms;
    for (int r = 0; r < repeat; ++r) {
      const auto t0 = Clock::now();
      if (auto st = a->upload(data.data(), bytes); !st) {
        std::fprintf(stderr, "gauss-bench vk: %s\n", st.message().c_str());
        return 1;
      }
      up_ms.push_back(ms_since(t0));
      gauss::Status copied = gauss::Ok{};
      auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
        q->reset(cmd);
        q->write(cmd, 0);
        const VkBufferCopy region{0, 0, bytes};
        copied = gauss::vk::record_copy(cmd, *a, *b, {&region, 1});
        q->write(cmd, 1);
      });
      auto ns = q->elapsed_ns(0, 1);
      if (!st || !copied || !ns) {
        std::fprintf(stderr, "gauss-bench vk: GPU copy failed\n");
        return 1;
      }
      copy_ms.push_back(*ns * 1e-6);
    }
    std::vector<std::uint8_t> back(bytes);
    if (auto st = b->download(back.data(), bytes); !st) {
      std::fprintf(stderr, "gauss-bench vk: %s\n", st.message().c_str());
      return 1;
    }
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < bytes; ++i) wrong += back[i] != data[i] ? 1 : 0;
    const double up = median(up_ms);
    const double cp = median(copy_ms);
    uploads.push_back({{"mib", mib},
                       {"upload_ms", up},
                       {"upload_gib_s", (bytes / double(1 << 30)) / (up * 1e-3)},
                       {"gpu_copy_ms", cp},
                       {"gpu_copy_gib_s", (bytes / double(1 << 30)) / (cp * 1e-3)},
                       {"wrong_bytes", wrong},
                       {"mapped", a->host_visible()}});
  }
  out["uploads"] = uploads;
  out["repeat"] = repeat;

  std::printf("device: %s (subgroup %u)\n", ctx.device_name().c_str(), ctx.subgroup_size());
  std::printf("%-34s %12s %12s\n", "measure", "median", "first/check");
  std::printf("%-34s %9.1f ms %9.1f ms\n", "context create", out["context_create_ms"]["median"].get<double>(),
              out["context_create_ms"]["first"].get<double>());
  std::printf("%-34s %9.1f ms %9.1f ms\n", "context create (validation)",
              out["context_create_validation_ms"]["median"].get<double>(),
              out["context_create_validation_ms"]["first"].get<double>());
  std::printf("%-34s %9.3f ms %8zu diff\n", "dispatch 1024x1024 (GPU timestamps)",
              out["dispatch_1024"]["gpu_ms_median"].get<double>(), differing_runs);
  std::printf("%-34s %9.3f ms\n", "dispatch 1024x1024 (submit+wait)",
              out["dispatch_1024"]["submit_wait_ms_median"].get<double>());
  for (const auto& c : chains) {
    char label[96];
    std::snprintf(label, sizeof(label), "1-group dispatch, %s", c["case"].get<std::string>().c_str());
    std::printf("%-50s %9.2f us\n", label, c["us_per_dispatch_median"].get<double>());
  }
  for (const auto& u : uploads) {
    char label[64];
    std::snprintf(label, sizeof(label), "upload %3zu MiB (%s)", u["mib"].get<std::size_t>(),
                  u["mapped"].get<bool>() ? "mapped" : "staged");
    std::printf("%-34s %7.2f GiB/s %7zu wrong\n", label, u["upload_gib_s"].get<double>(), u["wrong_bytes"].get<std::size_t>());
    std::snprintf(label, sizeof(label), "GPU copy %3zu MiB", u["mib"].get<std::size_t>());
    std::printf("%-34s %7.2f GiB/s\n", label, u["gpu_copy_gib_s"].get<double>());
  }
  if (!json_path.empty()) {
    if (!write_json(json_path, out, "vk")) return 1;
  }
  return 0;
}

BenchRun bench_vk_setup(CLI::App& cmd) {
  auto o = std::make_shared<VkBenchOptions>();
  cmd.add_option("--device", o->device, "Vulkan device index or name substring (else $GAUSS_DEVICE, else the best)")
      ->type_name("NAME");
  cmd.add_option("--repeat", o->repeat, "timed repetitions of each measurement")
      ->check(gauss::apps::at_least(1))
      ->type_name("N");
  cmd.add_option("--json", o->json_path, "write the results as JSON")->type_name("PATH");
  return [o] { return run_vk(*o); };
}

}  // namespace

GAUSS_BENCH("vk", "Vulkan core: context creation, 1024^2 dispatch, upload throughput", bench_vk_setup);
