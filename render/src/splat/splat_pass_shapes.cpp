// The device profile of the splat passes: which shapes (SplatPassShapes) a renderer takes
// on a device, decided once when its pipelines are created.
//
// What decides it (docs/DESIGN.md "What lavapipe charges", "What GPUs charge"):
// - Device type. CPU Vulkan (lavapipe) runs a subgroup as SIMD lanes of one core and
//   turns every non-constant load into a loop over the lanes: fewer threads with long
//   contiguous runs win there, and the CPU shapes were measured on it. Every other type is
//   a GPU, which wants consecutive invocations on consecutive words, many workgroups per
//   pass and no serial runs: the GPU shapes.
// - Subgroup size. The GPU shapes rank by ballot and keep one shared row per subgroup,
//   sized for 4..128 invocations (splat_layout.h SPLAT_MAX_SUBGROUPS); a device outside
//   that range keeps the CPU shapes, which use no subgroup operation in these passes.
// - Full subgroups. The GPU shapes number invocations by (subgroup, lane); a workgroup of
//   256 made of full subgroups is what every driver does for power-of-two sizes up to 128,
//   and the pipelines require it where the device has computeFullSubgroups (Vulkan 1.3).
// - Shared memory. The CPU radix scatter holds 16 x 256 counts (17.1 KiB in all), above
//   Vulkan's guaranteed 16 KiB; the GPU shapes need 4.4 KiB with 4-bit digits. A device
//   with less than the CPU shapes need gets the GPU shapes when its subgroups allow.
// - Digit width (GPU shapes). Every radix pass is three dispatches whose fixed cost
//   dominates small scenes on a GPU, so 8-bit digits (4 passes over a depth key, not 8)
//   are taken where the scatter's rows (one per subgroup, 256 words each) fit in 19.3 KiB
//   of shared memory: subgroups of 16 or more (NVIDIA 32, AMD 32/64, Mali 16, Adreno
//   64/128). Smaller subgroups keep 4-bit digits (lavapipe's 4 and 8, some Intel).
#include <algorithm>
#include <cstdlib>
#include <string>
#include <string_view>

#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "splat_layout.h"

namespace gauss::render {

namespace {

// Shared memory of the largest pass of each shape (bytes), see the shaders' shared arrays.
constexpr std::uint32_t kCpuShapesShared = (gpu::SORT_BINS * gpu::SPLAT_WORKGROUP + gpu::SORT_BINS * 16 + gpu::SORT_BINS) * 4;
// sort_radix_scatter_gpu.comp: s_off (rows x bins), s_total, s_base and s_before (bins
// each), and splat_subgroup.glsl's s_wg_sub.
constexpr std::uint32_t gpu_scatter_shared(std::uint32_t rows, std::uint32_t bits) {
  return (rows * (1u << bits) + 3u * (1u << bits) + gpu::SPLAT_MAX_SUBGROUPS) * 4;
}
constexpr std::uint32_t kGpuShapesShared = gpu_scatter_shared(gpu::SPLAT_MAX_SUBGROUPS, 4);
// 8-bit digits only where their scatter fits Vulkan's guaranteed 16 KiB plus a little:
// subgroups of 16 and up (16 rows: 19.3 KiB; 32-wide: 11.3 KiB).
constexpr std::uint32_t kWideDigitShared = gpu_scatter_shared(16, gpu::SORT_RADIX_BITS_MAX);

bool subgroups_fit_gpu_shapes(const vk::Context& context) {
  return context.subgroup_size() >= 4 && context.max_subgroup_size() <= 128 &&
         gpu::SPLAT_WORKGROUP / context.subgroup_size() <= gpu::SPLAT_MAX_SUBGROUPS;
}

std::string describe(const vk::Context& context, const char* why) {
  const VkPhysicalDeviceProperties& p = context.properties();
  return std::string(why) + "; " + vk::device_type_name(p.deviceType) + " device, subgroup " +
         std::to_string(context.subgroup_size()) + ", " +
         std::to_string(p.limits.maxComputeSharedMemorySize / 1024) + " KiB shared" +
         (context.enabled_features13().computeFullSubgroups ? ", full subgroups" : "");
}

}  // namespace

const char* pass_shapes_name(SplatPassShapes shapes) noexcept {
  switch (shapes) {
    case SplatPassShapes::Auto: return "auto";
    case SplatPassShapes::Cpu: return "cpu";
    case SplatPassShapes::Gpu: return "gpu";
  }
  return "auto";
}

Expected<SplatPassProfile> choose_pass_shapes(const vk::Context& context, SplatPassShapes requested) {
  const char* why = "asked for";
  if (requested == SplatPassShapes::Auto) {
    if (const char* env = std::getenv("GAUSS_PASS_SHAPES"); env && *env) {
      const std::string_view v = env;
      if (v == "cpu") requested = SplatPassShapes::Cpu;
      else if (v == "gpu") requested = SplatPassShapes::Gpu;
      else if (v != "auto")
        return Error{"GAUSS_PASS_SHAPES=" + std::string(v) + ": expected cpu, gpu or auto"};
      why = "GAUSS_PASS_SHAPES";
    }
  }
  if (requested == SplatPassShapes::Auto) {
    const bool cpu_device = context.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    const bool cpu_fits = context.limits().maxComputeSharedMemorySize >= kCpuShapesShared;
    if (!subgroups_fit_gpu_shapes(context)) {
      requested = SplatPassShapes::Cpu;
      why = "subgroups outside 4..128";
    } else if (cpu_device && cpu_fits) {
      requested = SplatPassShapes::Cpu;
      why = "CPU Vulkan";
    } else {
      requested = SplatPassShapes::Gpu;
      why = cpu_device ? "too little shared memory for the CPU shapes" : "GPU";
    }
  }
  if (requested == SplatPassShapes::Gpu && !subgroups_fit_gpu_shapes(context))
    return Error{"splat renderer: the GPU pass shapes need subgroups of 4..128 invocations; device " +
                 context.device_name() + " has " + std::to_string(context.subgroup_size()) + ".." +
                 std::to_string(context.max_subgroup_size())};
  const std::uint32_t shared = context.limits().maxComputeSharedMemorySize;
  const std::uint32_t need = requested == SplatPassShapes::Gpu ? kGpuShapesShared : kCpuShapesShared;
  if (shared < need)
    return Error{std::string("splat renderer: the ") + pass_shapes_name(requested) + " pass shapes need " +
                 std::to_string(need) + " bytes of compute shared memory; device " + context.device_name() +
                 " has " + std::to_string(shared)};
  SplatPassProfile profile;
  profile.shapes = requested;
  std::string digits = "4-bit digits";
  if (requested == SplatPassShapes::Gpu) {
    profile.sort_rows = gpu::SPLAT_WORKGROUP / std::max(context.min_subgroup_size(), 4u);
    const std::uint32_t wide_need = gpu_scatter_shared(profile.sort_rows, gpu::SORT_RADIX_BITS_MAX);
    const bool wide_fits = wide_need <= kWideDigitShared && wide_need <= shared;
    profile.radix_bits = wide_fits ? gpu::SORT_RADIX_BITS_MAX : gpu::SORT_RADIX_BITS;
    digits = wide_fits ? "8-bit digits" : "4-bit digits (8-bit rows need " + std::to_string(wide_need) + " bytes)";
    if (const char* env = std::getenv("GAUSS_SORT_RADIX_BITS"); env && *env) {
      const std::string_view v = env;
      if (v != "4" && v != "8") return Error{"GAUSS_SORT_RADIX_BITS=" + std::string(v) + ": expected 4 or 8"};
      if (v == "8" && !wide_fits)
        return Error{"GAUSS_SORT_RADIX_BITS=8: the 8-bit radix scatter needs " + std::to_string(wide_need) +
                     " bytes of shared memory with subgroups of " + std::to_string(context.min_subgroup_size()) +
                     "; device " + context.device_name() + " allows " + std::to_string(std::min(shared, kWideDigitShared))};
      profile.radix_bits = v == "8" ? gpu::SORT_RADIX_BITS_MAX : gpu::SORT_RADIX_BITS;
      digits = std::string(v) + "-bit digits (GAUSS_SORT_RADIX_BITS)";
    }
  }
  profile.views_together = requested == SplatPassShapes::Gpu;
  const char* views_why = profile.views_together ? "GPU shapes" : "CPU shapes";
  if (const char* env = std::getenv("GAUSS_SPLAT_STEREO"); env && *env) {
    const std::string_view v = env;
    if (v != "together" && v != "apart") return Error{"GAUSS_SPLAT_STEREO=" + std::string(v) + ": expected together or apart"};
    profile.views_together = v == "together";
    views_why = "GAUSS_SPLAT_STEREO";
  }
  profile.views_reason =
      std::string(profile.views_together ? "two views together" : "two views one after the other") + " (" + views_why + ")";
  profile.reason = std::string(pass_shapes_name(requested)) + " (" + describe(context, why) + "; " + digits + ")";
  return profile;
}

}  // namespace gauss::render
