// TSDF fusion: validation, block allocation and voxel update for one RGB-D frame.
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "tsdf_impl.h"

namespace gauss {
namespace {

// Depths beyond this are not a sensor reading but corrupt data.
constexpr float kAbsurdDepth = 1000.0f;

Error frame_error(const RgbdFrame& f, const std::string& what) {
  return Error{"RGB-D frame '" + f.name + "': " + what};
}

std::optional<Error> validate(const RgbdFrame& f) {
  if (f.width == 0 || f.height == 0) return frame_error(f, "image size is zero");
  if (f.width > 16384 || f.height > 16384)
    return frame_error(f, "image size " + std::to_string(f.width) + "x" + std::to_string(f.height) + " is absurd");
  const std::size_t n = std::size_t(f.width) * f.height;
  if (f.depth.size() != n)
    return frame_error(f, "depth has " + std::to_string(f.depth.size()) + " samples, expected " +
                              std::to_string(f.width) + "x" + std::to_string(f.height) + " = " + std::to_string(n));
  if (!f.colour.pixels.empty() && (f.colour.width != f.width || f.colour.height != f.height ||
                                   f.colour.pixels.size() != n * 4))
    return frame_error(f, "colour image is " + std::to_string(f.colour.width) + "x" + std::to_string(f.colour.height) +
                              " but depth is " + std::to_string(f.width) + "x" + std::to_string(f.height));
  if (!(f.fx > 0) || !(f.fy > 0) || !std::isfinite(f.fx) || !std::isfinite(f.fy) || !std::isfinite(f.cx) ||
      !std::isfinite(f.cy))
    return frame_error(f, "intrinsics must be finite with fx, fy > 0");
  const glm::dmat4& T = f.camera_to_world;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(T[c][r])) return frame_error(f, "pose has a non-finite entry");
  if (T[0][3] != 0.0 || T[1][3] != 0.0 || T[2][3] != 0.0 || T[3][3] != 1.0)
    return frame_error(f, "pose bottom row is not 0 0 0 1");
  const glm::dmat3 R(T);
  const glm::dmat3 RtR = glm::transpose(R) * R;
  double dev = 0.0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) dev = std::max(dev, std::abs(RtR[c][r] - (c == r ? 1.0 : 0.0)));
  if (dev > 1e-4 || glm::determinant(R) <= 0.0) {
    std::ostringstream s;
    s << "pose rotation is not orthonormal (max |R^T R - I| = " << dev << ", det = " << glm::determinant(R) << ")";
    return frame_error(f, s.str());
  }
  for (std::size_t i = 0; i < n; ++i) {
    const float d = f.depth[i];
    if (std::isnan(d)) continue;  // missing
    if (d < 0.0f || d > kAbsurdDepth) {
      std::ostringstream s;
      s << "depth " << d << " m at pixel (row " << i / f.width << ", column " << i % f.width
        << ") is negative or absurd (> " << kAbsurdDepth << " m)";
      return frame_error(f, s.str());
    }
  }
  return std::nullopt;
}

}  // namespace

Expected<TsdfVolume> TsdfVolume::create(const TsdfConfig& config) {
  if (!(config.voxel_size > 0.0f) || !std::isfinite(config.voxel_size) || config.voxel_size > 10.0f)
    return Error{"TSDF: voxel size must be in (0, 10] m"};
  if (config.truncation < 0.0f || !std::isfinite(config.truncation))
    return Error{"TSDF: truncation distance must be finite and >= 0 (0 = 3 voxels)"};
  if (!(config.min_depth >= 0.0f) || !(config.max_depth > config.min_depth))
    return Error{"TSDF: depth range must satisfy 0 <= min_depth < max_depth"};
  if (config.max_blocks == 0 || config.chunk_blocks == 0 || config.chunk_blocks > 64 || !(config.max_weight >= 1.0f))
    return Error{"TSDF: max_blocks and chunk_blocks (<= 64) must be positive and max_weight >= 1"};
  auto impl = std::make_unique<Impl>();
  impl->config = config;
  impl->truncation = config.truncation > 0.0f ? config.truncation : 3.0f * config.voxel_size;
  return TsdfVolume(std::move(impl));
}

TsdfVolume::TsdfVolume(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TsdfVolume::TsdfVolume(TsdfVolume&&) noexcept = default;
TsdfVolume& TsdfVolume::operator=(TsdfVolume&&) noexcept = default;
TsdfVolume::~TsdfVolume() = default;

const TsdfConfig& TsdfVolume::config() const { return impl_->config; }

TsdfStats TsdfVolume::stats() const {
  TsdfStats s = impl_->stats;
  s.blocks = impl_->blocks.size();
  s.bytes = s.blocks * (sizeof(TsdfBlock) + 32);  // + hash node overhead, approximately
  return s;
}

Status TsdfVolume::integrate(const RgbdFrame& f) {
  Impl& m = *impl_;
  if (auto err = validate(f)) {
    ++m.stats.frames_rejected;
    return *err;
  }
  const glm::dmat3 R(f.camera_to_world);
  const glm::dvec3 C(f.camera_to_world[3]);
  const glm::dmat3 Rt = glm::transpose(R);
  const double vs = m.config.voxel_size;
  const double block_m = vs * kBlockVoxels;
  const double trunc = m.truncation;
  auto usable = [&](float d) { return std::isfinite(d) && d >= m.config.min_depth && d <= m.config.max_depth; };

  // 1. Blocks within the truncation band of every observed point.
  std::vector<std::uint64_t> touched;
  const int steps = int(std::ceil(2.0 * trunc / (0.5 * block_m)));
  for (std::uint32_t i = 0; i < f.height; ++i) {
    for (std::uint32_t j = 0; j < f.width; ++j) {
      const float d = f.depth[std::size_t(i) * f.width + j];
      if (!usable(d)) continue;
      const glm::dvec3 ray_cam((j + 0.5 - f.cx) / f.fx, (i + 0.5 - f.cy) / f.fy, 1.0);
      const glm::dvec3 ray = R * ray_cam;  // world direction per unit of view depth
      for (int s = 0; s <= steps; ++s) {
        const double z = d - trunc + 2.0 * trunc * s / std::max(steps, 1);
        if (z <= 0.0) continue;
        const glm::dvec3 p = C + ray * z;
        const glm::ivec3 bk{int(std::floor(p.x / block_m)), int(std::floor(p.y / block_m)),
                            int(std::floor(p.z / block_m))};
        if (!key_in_range(bk)) continue;
        const std::uint64_t key = pack_key(bk);
        if (touched.empty() || touched.back() != key) touched.push_back(key);
      }
    }
  }
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  std::size_t fresh = 0;
  for (auto k : touched) fresh += m.blocks.count(k) == 0;
  if (m.blocks.size() + fresh > m.config.max_blocks) {
    ++m.stats.frames_rejected;
    return frame_error(f, "needs " + std::to_string(fresh) + " new blocks but the volume holds " +
                              std::to_string(m.blocks.size()) + " of at most " +
                              std::to_string(m.config.max_blocks) + " (raise TsdfConfig::max_blocks)");
  }

  // 2. Project every voxel of the touched blocks and update it. Nothing below can fail.
  const bool has_colour = !f.colour.pixels.empty();
  const float max_w = m.config.max_weight;
  for (auto key : touched) {
    const glm::ivec3 bk = unpack_key(key);
    TsdfBlock& block = m.blocks[key];
    bool wrote = false;
    for (int z = 0; z < kBlockVoxels; ++z)
      for (int y = 0; y < kBlockVoxels; ++y)
        for (int x = 0; x < kBlockVoxels; ++x) {
          const glm::dvec3 pw = (glm::dvec3(bk * kBlockVoxels + glm::ivec3(x, y, z)) + 0.5) * vs;
          const glm::dvec3 pc = Rt * (pw - C);
          if (pc.z <= 0.0) continue;
          const double u = f.fx * pc.x / pc.z + f.cx, v = f.fy * pc.y / pc.z + f.cy;
          if (!(u >= 0.0 && v >= 0.0 && u < f.width && v < f.height)) continue;
          const std::size_t pix = std::size_t(v) * f.width + std::size_t(u);
          const float d = f.depth[pix];
          if (!usable(d)) continue;
          const double sdf = d - pc.z;
          if (sdf < -trunc) continue;  // occluded: behind the observed surface
          const float tsdf = float(std::min(1.0, sdf / trunc));
          TsdfVoxel& vx = block.voxels[std::size_t((z * kBlockVoxels + y) * kBlockVoxels + x)];
          const float w = vx.weight;
          vx.sdf = (vx.sdf * w + tsdf) / (w + 1.0f);
          if (has_colour) {
            const std::uint8_t* c = &f.colour.pixels[pix * 4];
            auto mix = [&](std::uint8_t old, std::uint8_t now) {
              return std::uint8_t(std::lround((float(old) * w + float(now)) / (w + 1.0f)));
            };
            vx.r = mix(vx.r, c[0]);
            vx.g = mix(vx.g, c[1]);
            vx.b = mix(vx.b, c[2]);
          } else if (w == 0.0f) {
            vx.r = vx.g = vx.b = 200;
          }
          vx.weight = std::min(w + 1.0f, max_w);
          wrote = true;
        }
    if (!wrote) continue;
    block.epoch = std::max(block.epoch, f.epoch);
    // This block is read by cells of its own chunk and, on its lower faces, by the
    // chunks below it: all of those must be re-extracted.
    for (int dz = -1; dz <= 0; ++dz)
      for (int dy = -1; dy <= 0; ++dy)
        for (int dx = -1; dx <= 0; ++dx)
          m.dirty_chunks.insert(pack_key(m.chunk_of_block(bk + glm::ivec3(dx, dy, dz))));
  }
  ++m.stats.frames_integrated;
  return Ok{};
}

float TsdfVolume::sample(const glm::vec3& world, float* out_weight) const {
  const Impl& m = *impl_;
  const glm::dvec3 g = glm::dvec3(world) / double(m.config.voxel_size) - 0.5;
  const glm::ivec3 g0{int(std::floor(g.x)), int(std::floor(g.y)), int(std::floor(g.z))};
  const glm::dvec3 t = g - glm::dvec3(g0);
  double sdf = 0.0, wsum = 0.0;
  for (int c = 0; c < 8; ++c) {
    const glm::ivec3 o{c & 1, (c >> 1) & 1, (c >> 2) & 1};
    const TsdfVoxel* v = m.voxel(g0 + o);
    if (!v || v->weight == 0.0f) {
      if (out_weight) *out_weight = 0.0f;
      return m.truncation;
    }
    const double w = (o.x ? t.x : 1 - t.x) * (o.y ? t.y : 1 - t.y) * (o.z ? t.z : 1 - t.z);
    sdf += w * v->sdf;
    wsum += w * v->weight;
  }
  if (out_weight) *out_weight = float(wsum);
  return float(sdf * m.truncation);
}

}  // namespace gauss
