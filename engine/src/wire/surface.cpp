// SurfacePatch: one TSDF mesh chunk, zstd-compressed on the wire.
// Body: u64 epoch | u64 chunk_id | u32 vertex_count | u32 index_count |
//       u32 compressed_size | zstd frame of (positions f32x3 | colors u8x3 | indices u32), all LE.
// The decompressed size follows from the two counts (both bounded by the schema),
// and the zstd frame must declare exactly that size, so a forged frame can never
// make the decoder allocate beyond the schema's chunk bound.
#include <string>

#include <zstd.h>

#include "codecs.h"
#include "gauss/engine/wire.h"

namespace gauss::msg {

bool operator==(const SurfacePatch& a, const SurfacePatch& b) {
  return a.epoch == b.epoch && a.chunk_id == b.chunk_id && a.mesh.positions == b.mesh.positions &&
         a.mesh.colors == b.mesh.colors && a.mesh.indices == b.mesh.indices;
}

}  // namespace gauss::msg

namespace gauss::wire {
namespace detail {
namespace {

// Level 3 is zstd's default: fast enough for a chunk per epoch, ~2-3x on meshes.
constexpr int kZstdLevel = 3;

std::size_t raw_size(std::size_t vertices, std::size_t indices) { return vertices * 15 + indices * 4; }

}  // namespace

Status check(const msg::SurfacePatch& m) {
  const auto& mesh = m.mesh;
  if (mesh.positions.size() > msg::kMaxChunkVertices)
    return field_error("SurfacePatch", "mesh.positions", std::to_string(mesh.positions.size()) + " vertices exceed " + std::to_string(msg::kMaxChunkVertices));
  if (mesh.colors.size() != mesh.positions.size())
    return field_error("SurfacePatch", "mesh.colors", "count differs from positions");
  if (mesh.indices.size() > msg::kMaxChunkIndices)
    return field_error("SurfacePatch", "mesh.indices", std::to_string(mesh.indices.size()) + " indices exceed " + std::to_string(msg::kMaxChunkIndices));
  if (mesh.indices.size() % 3 != 0) return field_error("SurfacePatch", "mesh.indices", "count not a multiple of 3");
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    if (!finite3(mesh.positions[i]))
      return field_error("SurfacePatch", "mesh.positions[" + std::to_string(i) + "]", "not finite");
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.positions.size())
      return field_error("SurfacePatch", "mesh.indices[" + std::to_string(i) + "]",
                         std::to_string(mesh.indices[i]) + " >= vertex count " + std::to_string(mesh.positions.size()));
  return Ok{};
}

Status write(const msg::SurfacePatch& m, Writer& w) {
  const auto& mesh = m.mesh;
  std::vector<std::uint8_t> raw;
  raw.reserve(raw_size(mesh.positions.size(), mesh.indices.size()));
  Writer rw(raw);
  for (const auto& p : mesh.positions) rw.vec3(p);
  for (const auto& c : mesh.colors) {
    rw.u8(c.x);
    rw.u8(c.y);
    rw.u8(c.z);
  }
  for (std::uint32_t i : mesh.indices) rw.u32(i);

  std::vector<std::uint8_t> packed(ZSTD_compressBound(raw.size()));
  const std::size_t n = ZSTD_compress(packed.data(), packed.size(), raw.data(), raw.size(), kZstdLevel);
  if (ZSTD_isError(n)) return field_error("SurfacePatch", "mesh", std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
  packed.resize(n);

  w.u64(to_underlying(m.epoch));
  w.u64(m.chunk_id);
  w.u32(static_cast<std::uint32_t>(mesh.positions.size()));
  w.u32(static_cast<std::uint32_t>(mesh.indices.size()));
  w.bytes(packed);
  return Ok{};
}

}  // namespace detail

Expected<msg::SurfacePatch> decode_surface_patch(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "SurfacePatch");
  msg::SurfacePatch m;
  std::uint64_t epoch = 0;
  std::uint32_t vertices = 0, indices = 0, packed_size = 0;
  r.u64("epoch", epoch);
  m.epoch = Epoch{epoch};
  r.u64("chunk_id", m.chunk_id);
  r.count("vertex_count", vertices, msg::kMaxChunkVertices, 0);
  const std::size_t index_at = r.offset();
  r.count("index_count", indices, msg::kMaxChunkIndices, 0);
  if (r.ok() && indices % 3 != 0) r.fail_at("index_count", index_at, std::to_string(indices) + " not a multiple of 3");
  r.count("compressed_size", packed_size, msg::kMaxMessageBytes, 1);
  std::span<const std::uint8_t> packed;
  const std::size_t packed_at = r.offset();
  r.view("compressed", packed_size, packed);
  if (!r.finish()) return r.error();

  // The zstd frame's problems are reported like any other field's.
  const auto bad_frame = [&](const std::string& what) {
    r.fail_at("compressed", packed_at, what);
    return r.error();
  };
  const std::size_t expected = detail::raw_size(vertices, indices);
  const unsigned long long declared = ZSTD_getFrameContentSize(packed.data(), packed.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN)
    return bad_frame("not a zstd frame with a declared content size");
  if (declared != expected)
    return bad_frame("declares " + std::to_string(declared) + " bytes, counts need " + std::to_string(expected));
  std::vector<std::uint8_t> raw(expected);
  const std::size_t got = ZSTD_decompress(raw.data(), raw.size(), packed.data(), packed.size());
  if (ZSTD_isError(got)) return bad_frame(std::string("zstd: ") + ZSTD_getErrorName(got));
  if (got != expected)
    return bad_frame("decompressed " + std::to_string(got) + " bytes, expected " + std::to_string(expected));

  // The raw block is read with the same reader so non-finite positions are named.
  detail::Reader rr(raw, "SurfacePatch(decompressed)");
  m.mesh.positions.resize(vertices);
  m.mesh.colors.resize(vertices);
  m.mesh.indices.resize(indices);
  for (auto& p : m.mesh.positions) rr.vec3("mesh.positions", p);
  for (auto& c : m.mesh.colors) {
    rr.u8("mesh.colors", c.x);
    rr.u8("mesh.colors", c.y);
    rr.u8("mesh.colors", c.z);
  }
  for (auto& i : m.mesh.indices) rr.u32("mesh.indices", i);
  if (!rr.finish()) return rr.error();
  return detail::checked(std::move(m));
}

}  // namespace gauss::wire
