// antimatter15 .splat reader (splat_file.h).
//
// Format: no header, one 32-byte little-endian record per Gaussian, in the PLY's coordinates:
//   bytes  0..11  position    3 x float32                    exact
//   bytes 12..23  scale       3 x float32, linear (metres)   log_scale = log(s): exact to float
//                                                            rounding (s must be > 0 and finite)
//   bytes 24..27  colour RGBA 4 x uint8
//                   RGB: b = round(255 * (0.5 + SH_C0 * f_dc)) clamped to 0..255;
//                        decoded f_dc = (b / 255 - 0.5) / SH_C0. Step 1 / (255 SH_C0) = 0.01390,
//                        worst case 0.00695 for |f_dc| <= 1.7725 (a rounding writer; some writers
//                        truncate, which doubles that); larger |f_dc| was clamped by the writer.
//                   A:   b = round(255 * sigmoid(opacity)); decoded opacity_logit =
//                        logit(clamp(b / 255, 0.5 / 255, 1 - 0.5 / 255)). The clamp keeps 0 and 255
//                        finite (logit = -/+ln(509) = -/+6.2324) and still within half a step of any source
//                        opacity that rounds to them, so sigmoid(decoded) is within 0.5/255 of the
//                        source opacity (1/255 for a truncating writer). The logit error itself is
//                        unbounded near 0 and 1: compare opacities, not logits.
//   bytes 28..31  rotation    4 x uint8 (w, x, y, z), b = clamp(round(128 q + 128), 0, 255);
//                        decoded q = (b - 128) / 128, then normalised. Step 1/128; a component of +1
//                        stores as 255 (0.9921875). Before normalisation each component is within
//                        1/128 of the source, so the decoded unit quaternion is within
//                        2e / (1 - e) = 0.032 (e = 2/128, the error's length) of +-source.
// SH degree 0 (no higher bands). Zero quaternions (all four bytes 128) become the identity and
// are counted; every other decoded quaternion that is not unit within kQuaternionUnitTolerance is
// normalised and counted, as the PLY reader does.
//
// A record with a non-finite position, or a scale that is not positive and finite (its log
// would be -Inf or NaN), is left out and listed (report.dropped: its record index, the first
// named); the others keep their order and their record index as id. Errors name the input
// and the byte offset: an empty file, a size that is not a whole number of records, every
// record left out. Never a partial cloud.
#include <cmath>
#include <cstring>
#include <string>

#include "gauss/engine/splat_file.h"
#include "io/memory_room.h"
#include "io/ply_core.h"  // ply::format_double
#include "io/splat_quantized.h"

namespace gauss {
namespace {

constexpr std::size_t kRecordBytes = 32;

Error fail(std::string_view name, const std::string& what) { return Error{std::string(name) + ": " + what}; }

float read_f32(const std::uint8_t* p) {
  float v;
  std::memcpy(&v, p, sizeof v);  // little-endian hosts only, as everywhere in the engine
  return v;
}

}  // namespace

Expected<SplatScene> parse_antimatter_splat(std::span<const std::uint8_t> bytes, std::string_view name) {
  if (bytes.empty()) return fail(name, "empty file: no 32-byte record at byte offset 0");
  if (bytes.size() % kRecordBytes != 0) {
    const std::size_t last = bytes.size() / kRecordBytes * kRecordBytes;
    return fail(name, "truncated record at byte offset " + std::to_string(last) + ": " +
                          std::to_string(bytes.size() - last) + " of 32 bytes (file size " +
                          std::to_string(bytes.size()) + " is not a multiple of 32)");
  }
  const std::size_t count = bytes.size() / kRecordBytes;

  SplatScene scene;
  scene.report.format = SplatFormat::AntimatterSplat;
  scene.cloud.sh_degree = 0;
  std::vector<Gaussian>& gs = scene.cloud.gaussians;
  if (auto s = io::resize_cloud(gs, count, name); !s) return s.error();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t at = i * kRecordBytes;
    const std::uint8_t* r = bytes.data() + at;
    // Why the record cannot be a Gaussian, or empty.
    std::string bad;
    for (int k = 0; k < 3 && bad.empty(); ++k) {
      const float p = read_f32(r + 4 * k), s = read_f32(r + 12 + 4 * k);
      if (!std::isfinite(p))
        bad = "splat " + std::to_string(i) + ": non-finite position at byte offset " + std::to_string(at + 4 * std::size_t(k));
      else if (!(s > 0.0f) || !std::isfinite(s))
        bad = "splat " + std::to_string(i) + ": scale " + ply::format_double(s) + " at byte offset " +
              std::to_string(at + 12 + 4 * std::size_t(k)) + " is not positive and finite";
    }
    if (!bad.empty()) {
      if (scene.report.dropped.empty()) scene.report.first_dropped = bad;
      scene.report.dropped.push_back(i);
      continue;
    }
    Gaussian& g = gs[kept++];
    for (int k = 0; k < 3; ++k) {
      g.position[k] = read_f32(r + 4 * k);
      g.log_scale[k] = static_cast<float>(std::log(double(read_f32(r + 12 + 4 * k))));
      g.sh_dc[k] = static_cast<float>((double(r[24 + k]) / 255.0 - 0.5) / kShC0);
    }
    g.opacity_logit = io::alpha_to_logit(double(r[27]) / 255.0);
    g.rotation = glm::vec4((float(r[28]) - 128.0f) / 128.0f, (float(r[29]) - 128.0f) / 128.0f,
                           (float(r[30]) - 128.0f) / 128.0f, (float(r[31]) - 128.0f) / 128.0f);
  }
  if (kept == 0)
    return fail(name, "every one of its " + std::to_string(count) + " records is unusable (the first: " +
                          scene.report.first_dropped + ")");
  gs.resize(kept);
  io::finish_quantized_scene(scene);
  return scene;
}

}  // namespace gauss
