// Marching-cubes extraction of TSDF chunks into indexed, vertex-coloured meshes.
#include <algorithm>
#include <array>
#include <cmath>

#include "marching_cubes_table.h"
#include "tsdf_impl.h"

namespace gauss {
namespace {

// A cell's corner sample, gathered once per block with its +1 neighbours.
struct Corner {
  float sdf;
  float weight;
  std::uint8_t r, g, b;
};

constexpr int kPad = kBlockVoxels + 1;  // samples per axis a block's cells read

// FNV-1a over the mesh's bytes: detects a re-extracted chunk that did not change.
std::uint64_t mesh_hash(const TriangleMesh& m) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  };
  mix(m.positions.data(), m.positions.size() * sizeof(glm::vec3));
  mix(m.colors.data(), m.colors.size() * sizeof(glm::u8vec3));
  mix(m.indices.data(), m.indices.size() * sizeof(std::uint32_t));
  return h;
}

}  // namespace

TriangleMesh TsdfVolume::Impl::extract_chunk(const glm::ivec3& chunk, Epoch* out_epoch) const {
  TriangleMesh mesh;
  Epoch epoch{0};
  const auto& table = tsdf::marching_cubes_table();
  const int cb = int(config.chunk_blocks);
  const float vs = config.voxel_size;
  // Edge key -> vertex index: vertices shared by the cells of this chunk.
  std::unordered_map<std::uint64_t, std::uint32_t> vertex_of_edge;
  std::vector<Corner> local(std::size_t(kPad * kPad * kPad));

  for (int bz = 0; bz < cb; ++bz)
    for (int by = 0; by < cb; ++by)
      for (int bx = 0; bx < cb; ++bx) {
        const glm::ivec3 bk = chunk * cb + glm::ivec3(bx, by, bz);
        auto it = blocks.find(pack_key(bk));
        if (it == blocks.end()) continue;
        // The chunk's mesh depends on its blocks and on the +x/+y/+z neighbours its
        // boundary cells read: its epoch is the newest of all of them.
        for (int n = 0; n < 8; ++n) {
          auto nb = n == 0 ? it : blocks.find(pack_key(bk + glm::ivec3(n & 1, (n >> 1) & 1, (n >> 2) & 1)));
          if (nb != blocks.end()) epoch = std::max(epoch, nb->second.epoch);
        }
        const glm::ivec3 base = bk * kBlockVoxels;
        // Gather the 9^3 samples: the block itself plus the first layer of its +x/+y/+z
        // neighbours (absent neighbours read as unobserved).
        for (int z = 0; z < kPad; ++z)
          for (int y = 0; y < kPad; ++y)
            for (int x = 0; x < kPad; ++x) {
              const TsdfVoxel* v = (x < kBlockVoxels && y < kBlockVoxels && z < kBlockVoxels)
                                       ? &it->second.voxels[std::size_t((z * kBlockVoxels + y) * kBlockVoxels + x)]
                                       : voxel(base + glm::ivec3(x, y, z));
              Corner& c = local[std::size_t((z * kPad + y) * kPad + x)];
              c = v ? Corner{v->sdf, v->weight, v->r, v->g, v->b} : Corner{1.0f, 0.0f, 0, 0, 0};
            }
        for (int z = 0; z < kBlockVoxels; ++z)
          for (int y = 0; y < kBlockVoxels; ++y)
            for (int x = 0; x < kBlockVoxels; ++x) {
              std::array<const Corner*, 8> cs{};
              int mask = 0;
              bool observed = true;
              for (std::size_t corner = 0; corner < cs.size(); ++corner) {
                const int ox = int(corner & 1), oy = int((corner >> 1) & 1), oz = int((corner >> 2) & 1);
                const Corner& sample = local[std::size_t(((z + oz) * kPad + (y + oy)) * kPad + (x + ox))];
                cs[corner] = &sample;
                observed = observed && sample.weight > 0.0f;
                if (sample.sdf < 0.0f) mask |= 1 << corner;
              }
              if (!observed || mask == 0 || mask == 255) continue;
              const tsdf::McCase& mc = table[std::size_t(mask)];
              std::uint32_t idx[12];
              for (int t = 0; t < 3 * mc.triangle_count; ++t) {
                const int e = mc.edges[std::size_t(t)];
                const int c0 = tsdf::kEdgeCorners[std::size_t(e)][0], c1 = tsdf::kEdgeCorners[std::size_t(e)][1];
                const glm::ivec3 g0 = base + glm::ivec3(x + (c0 & 1), y + ((c0 >> 1) & 1), z + ((c0 >> 2) & 1));
                // Edge id: its lower corner's global voxel + axis (e / 4). The same edge
                // seen from a neighbouring chunk gets the same position bit for bit,
                // because both interpolate from the lower corner with the same inputs.
                const std::uint64_t key = (pack_key(g0) << 2) | std::uint64_t(e / 4);
                auto [vit, inserted] = vertex_of_edge.try_emplace(key, std::uint32_t(mesh.positions.size()));
                if (inserted) {
                  const Corner& a = *cs[std::size_t(c0)];
                  const Corner& b = *cs[std::size_t(c1)];
                  const float s = a.sdf / (a.sdf - b.sdf);
                  const glm::vec3 pa = (glm::vec3(g0) + 0.5f) * vs;
                  glm::vec3 p = pa;
                  p[e / 4] += s * vs;
                  mesh.positions.push_back(p);
                  auto lerp8 = [s](std::uint8_t u, std::uint8_t w) {
                    return std::uint8_t(std::lround(float(u) + s * (float(w) - float(u))));
                  };
                  mesh.colors.push_back({lerp8(a.r, b.r), lerp8(a.g, b.g), lerp8(a.b, b.b)});
                }
                idx[t % 3] = vit->second;
                if (t % 3 == 2) {
                  // Drop triangles collapsed onto one vertex (a corner exactly at zero).
                  if (idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2]) continue;
                  mesh.indices.insert(mesh.indices.end(), {idx[0], idx[1], idx[2]});
                }
              }
            }
      }
  if (out_epoch) *out_epoch = epoch;
  return mesh;
}

std::vector<SurfaceEdit> TsdfVolume::extract_changed() {
  Impl& m = *impl_;
  std::vector<std::uint64_t> dirty(m.dirty_chunks.begin(), m.dirty_chunks.end());
  std::sort(dirty.begin(), dirty.end());  // deterministic order
  m.dirty_chunks.clear();
  std::vector<SurfaceEdit> edits;
  for (auto key : dirty) {
    SurfaceEdit e;
    auto [idit, fresh] = m.chunk_ids.try_emplace(key, std::uint32_t(m.chunk_ids.size()));
    if (fresh) m.chunk_keys.emplace(idit->second, key);
    e.chunk_id = idit->second;
    e.mesh = m.extract_chunk(unpack_key(key), &e.epoch);
    auto had = m.emitted_chunks.find(key);
    if (e.mesh.indices.empty()) {
      if (had == m.emitted_chunks.end()) continue;
      e.kind = SurfaceEditKind::Remove;
      e.mesh = {};
      m.emitted_chunks.erase(had);
    } else {
      // A chunk dirtied only through a neighbour often comes out identical: don't resend it.
      const std::uint64_t hash = mesh_hash(e.mesh);
      if (had != m.emitted_chunks.end() && had->second == hash) continue;
      e.kind = had != m.emitted_chunks.end() ? SurfaceEditKind::Replace : SurfaceEditKind::Add;
      m.emitted_chunks[key] = hash;
    }
    edits.push_back(std::move(e));
  }
  return edits;
}

TriangleMesh TsdfVolume::chunk_mesh(std::uint32_t chunk_id) const {
  auto it = impl_->chunk_keys.find(chunk_id);
  if (it == impl_->chunk_keys.end()) return {};
  return impl_->extract_chunk(unpack_key(it->second), nullptr);
}

TriangleMesh TsdfVolume::extract_all() const {
  const Impl& m = *impl_;
  std::vector<std::uint64_t> chunks;
  for (const auto& [key, block] : m.blocks) chunks.push_back(pack_key(m.chunk_of_block(unpack_key(key))));
  std::sort(chunks.begin(), chunks.end());
  chunks.erase(std::unique(chunks.begin(), chunks.end()), chunks.end());
  TriangleMesh all;
  for (auto key : chunks) {
    TriangleMesh part = m.extract_chunk(unpack_key(key), nullptr);
    const auto offset = std::uint32_t(all.positions.size());
    all.positions.insert(all.positions.end(), part.positions.begin(), part.positions.end());
    all.colors.insert(all.colors.end(), part.colors.begin(), part.colors.end());
    for (auto i : part.indices) all.indices.push_back(offset + i);
  }
  return all;
}

}  // namespace gauss
