#pragma once
// Private state of TsdfVolume, shared by integration (tsdf_volume.cpp) and
// extraction (tsdf_extract.cpp).
#include <array>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>

#include <glm/vec3.hpp>

#include "gauss/engine/tsdf.h"

namespace gauss {

inline constexpr int kBlockVoxels = 8;  // voxels per block edge
inline constexpr int kBlockSize = kBlockVoxels * kBlockVoxels * kBlockVoxels;

struct TsdfVoxel {
  float sdf{1.0f};     // mean signed distance / truncation, in [-1, 1]; free space positive
  float weight{0.0f};  // 0 = never observed
  std::uint8_t r{0}, g{0}, b{0};
  std::uint8_t pad{0};
};
static_assert(sizeof(TsdfVoxel) == 12);

struct TsdfBlock {
  std::array<TsdfVoxel, kBlockSize> voxels{};
  Epoch epoch{0};  // newest frame that wrote into this block
};

// Integer coordinates packed 21 bits per axis (offset binary): +-2^20 blocks covers
// +-80 km at 1 cm voxels, far beyond any room.
inline std::uint64_t pack_key(const glm::ivec3& k) {
  constexpr std::int64_t kOffset = 1 << 20;
  return (std::uint64_t(std::int64_t(k.x) + kOffset) << 42) | (std::uint64_t(std::int64_t(k.y) + kOffset) << 21) |
         std::uint64_t(std::int64_t(k.z) + kOffset);
}
inline glm::ivec3 unpack_key(std::uint64_t p) {
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::uint64_t kMask = (1u << 21) - 1;
  return {int(std::int64_t((p >> 42) & kMask) - kOffset), int(std::int64_t((p >> 21) & kMask) - kOffset),
          int(std::int64_t(p & kMask) - kOffset)};
}
inline int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline bool key_in_range(const glm::ivec3& k) {
  constexpr int kLimit = (1 << 20) - 2;
  return k.x > -kLimit && k.x < kLimit && k.y > -kLimit && k.y < kLimit && k.z > -kLimit && k.z < kLimit;
}

struct TsdfVolume::Impl {
  TsdfConfig config;
  float truncation{0.0f};
  std::unordered_map<std::uint64_t, TsdfBlock> blocks;   // packed block key -> block
  std::unordered_set<std::uint64_t> dirty_chunks;        // packed chunk keys
  std::unordered_map<std::uint64_t, std::uint64_t> emitted_chunks;  // chunk -> hash of the mesh clients hold
  std::unordered_map<std::uint64_t, std::uint32_t> chunk_ids;       // packed chunk key -> public chunk id
  std::unordered_map<std::uint32_t, std::uint64_t> chunk_keys;      // and back
  TsdfStats stats;

  const TsdfVoxel* voxel(const glm::ivec3& global) const {
    const glm::ivec3 bk{floor_div(global.x, kBlockVoxels), floor_div(global.y, kBlockVoxels),
                        floor_div(global.z, kBlockVoxels)};
    auto it = blocks.find(pack_key(bk));
    if (it == blocks.end()) return nullptr;
    const glm::ivec3 l = global - bk * kBlockVoxels;
    return &it->second.voxels[std::size_t((l.z * kBlockVoxels + l.y) * kBlockVoxels + l.x)];
  }
  glm::ivec3 chunk_of_block(const glm::ivec3& bk) const {
    const int c = int(config.chunk_blocks);
    return {floor_div(bk.x, c), floor_div(bk.y, c), floor_div(bk.z, c)};
  }
  TriangleMesh extract_chunk(const glm::ivec3& chunk, Epoch* out_epoch) const;
};

}  // namespace gauss
