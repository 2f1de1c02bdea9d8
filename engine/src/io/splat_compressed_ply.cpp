// PlayCanvas compressed PLY reader (splat_file.h).
//
// Layout (binary PLY, either byte order; ascii is rejected):
//   element chunk   ceil(n / 256) items, float: min_x min_y min_z max_x max_y max_z
//                   min_scale_x .. min_scale_z max_scale_x .. max_scale_z, and in files from
//                   2024 on min_r min_g min_b max_r max_g max_b (all six or none)
//   element vertex  n items, uint: packed_position packed_rotation packed_scale packed_color;
//                   splat i belongs to chunk i / 256
//   element sh      optional, n items, uchar f_rest_0 .. f_rest_{3k-1}, k = 3, 8 or 15 (SH
//                   degree 1..3), channel-major as in the 3DGS PLY
// Properties may come in any order within an element; any other element or property is an
// error (the format has no extension points, and a misread quantised field is silent garbage).
//
// Quantisation (the writer, splat-transform's CompressedChunk, rounds to nearest; t = stored
// integer / (2^bits - 1), decoded value = min * (1 - t) + max * t with the chunk's bounds):
//   position    11/10/11 bits (x: bits 21-31, y: 11-20, z: 0-10) within the chunk's box:
//               error <= extent / 4094 for x and z, extent / 2046 for y (a chunk extent below
//               1e-5 stores every interior splat at the minimum: error <= 1e-5)
//   log-scale   11/10/11 bits the same way within the chunk's log-scale bounds (the writer
//               clamps the bounds to [-20, 20])
//   rotation    bits 30-31: index of the largest component (0 = w); bits 20-29, 10-19, 0-9:
//               the other three in w x y z order, each c = (v / 1023 - 0.5) * sqrt(2), error
//               <= d = sqrt(2) / 2046 = 0.00069; the largest, m = sqrt(1 - a^2 - b^2 - c^2)
//               >= 1/2, is off by <= 3d = 0.0021 to first order; the result is unit up to
//               rounding and normalised when not (counted in the report)
//   colour      8 bits per channel (R: bits 24-31, G 16-23, B 8-15): colour = lerp within the
//               chunk's colour bounds when present, else the byte / 255 as is; f_dc =
//               (colour - 0.5) / SH_C0. Error <= colour extent / 510 / SH_C0 (0.00695 without
//               bounds, where the writer also clamps colours to [0, 1], i.e. |f_dc| <= 1.7725)
//   opacity     bits 0-7: alpha = byte / 255, error <= 0.5 / 255 in alpha; opacity_logit =
//               logit(clamp(alpha, 0.5/255, 1 - 0.5/255)): bytes 0 and 255 would give -/+Inf and
//               decode to -/+6.2324 instead (see splat_quantized.h; compare opacities, not logits)
//   sh rest     8 bits per coefficient, writer b = clamp(trunc((v / 8 + 0.5) * 256), 0, 255);
//               decoded at the bin centre (b + 0.5) / 256, v = (that - 0.5) * 8, except b = 0 ->
//               -4 and b = 255 -> +4 (splat-transform's decoder). Error <= 1/64 = 0.015625 for
//               |v| < 3.96875, <= 1/32 for 3.96875 <= |v| <= 4; |v| > 4 is clamped.
// Ids are the splat's index in the file; no object labels.
//
// Errors name the input and the byte offset: a header without end_header (the offset where
// the file stops), a non-finite chunk bound or a colour bound whose f_dc overflows a float, a
// chunk count other than ceil(n / 256), an sh count other than n, short data or bytes after
// the last element. Never a partial cloud.
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "gauss/engine/splat_file.h"
#include "io/memory_room.h"
#include "io/ply_core.h"
#include "io/splat_quantized.h"

namespace gauss {
namespace {

using ply::Element;
using ply::Header;
using ply::Property;
using ply::Type;

constexpr std::size_t kChunkSplats = 256;

// Chunk property slots: 0..11 required, 12..17 the optional colour bounds.
constexpr std::array<std::string_view, 18> kChunkProps{
    "min_x",       "min_y",       "min_z",       "max_x",       "max_y",       "max_z",
    "min_scale_x", "min_scale_y", "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z",
    "min_r",       "min_g",       "min_b",       "max_r",       "max_g",       "max_b"};
constexpr int kChunkRequired = 12;
constexpr std::array<std::string_view, 4> kVertexProps{"packed_position", "packed_rotation", "packed_scale",
                                                       "packed_color"};
constexpr int kMaxShProps = 3 * kMaxShRest;

// Where one element's items live and where each named property sits inside an item.
struct ElementLayout {
  const Element* element{nullptr};
  std::size_t offset{0};          // first byte of the element's data
  std::size_t stride{0};          // bytes per item
  std::vector<std::ptrdiff_t> at;  // per slot: byte offset inside an item, or -1 when absent
};

std::string where(const Property& p) { return "property '" + p.name + "' (header line " + std::to_string(p.header_line) + ")"; }

// "f_rest_<k>" -> k, or -1 (leading zeros rejected so "f_rest_01" cannot alias "f_rest_1").
int rest_index(std::string_view s) {
  constexpr std::string_view prefix = "f_rest_";
  if (s.size() <= prefix.size() || s.size() > prefix.size() + 2 || s.substr(0, prefix.size()) != prefix) return -1;
  const std::string_view digits = s.substr(prefix.size());
  if (digits.size() > 1 && digits[0] == '0') return -1;
  int v = 0;
  for (char c : digits) {
    if (c < '0' || c > '9') return -1;
    v = v * 10 + (c - '0');
  }
  return v;
}

// Maps every property of `e` to a slot (`slot_of` returns -1 for an unknown name) and checks
// its type. Byte offsets inside an item are filled into `layout.at`.
template <class SlotOf>
Status map_element(const Element& e, int slots, Type type, SlotOf slot_of, std::string_view name,
                   ElementLayout& layout) {
  layout.element = &e;
  layout.at.assign(static_cast<std::size_t>(slots), -1);
  std::size_t offset = 0;
  for (const Property& p : e.properties) {
    if (p.is_list)
      return ply::make_error(name, "element '" + e.name + "' " + where(p) +
                                       " is a list; a compressed PLY has only scalar properties");
    const int slot = slot_of(p.name);
    if (slot < 0)
      return ply::make_error(name, "element '" + e.name + "' has unexpected " + where(p) +
                                       " (not part of the PlayCanvas compressed layout)");
    if (p.type != type)
      return ply::make_error(name, "element '" + e.name + "' " + where(p) + " is " +
                                       std::string(ply::type_name(p.type)) + "; expected " +
                                       std::string(ply::type_name(type)));
    // The header parser rejects duplicate names, so each slot is set at most once.
    layout.at[static_cast<std::size_t>(slot)] = static_cast<std::ptrdiff_t>(offset);
    offset += ply::type_size(p.type);
  }
  layout.stride = offset;
  return Ok{};
}

std::string missing(const Element& e, std::string_view prop) {
  return "element '" + e.name + "' (header line " + std::to_string(e.header_line) + ") has no property '" +
         std::string(prop) + "'";
}

// Whether the file holds a complete header line "end_header".
bool has_complete_header(std::span<const std::uint8_t> bytes) {
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()),
                              std::min<std::size_t>(bytes.size(), ply::kMaxHeaderBytes));
  for (std::size_t at = text.find("end_header"); at != std::string_view::npos; at = text.find("end_header", at + 1)) {
    const std::size_t after = at + 10;
    if ((at == 0 || text[at - 1] == '\n') && after < text.size() && (text[after] == '\n' || text[after] == '\r'))
      return true;
  }
  return false;
}

double unorm(std::uint32_t v, int bits) {
  const std::uint32_t top = (1u << bits) - 1u;
  return double(v & top) / double(top);
}

double lerp(float lo, float hi, double t) { return double(lo) * (1.0 - t) + double(hi) * t; }

// splat-transform's decoding of an 8-bit SH coefficient (bin centre; the end bins at +-4).
float sh_from_byte(std::uint8_t b) {
  if (b == 0) return -4.0f;
  if (b == 255) return 4.0f;
  return static_cast<float>(((double(b) + 0.5) / 256.0 - 0.5) * 8.0);
}

}  // namespace

Expected<SplatScene> parse_compressed_ply(std::span<const std::uint8_t> bytes, std::string_view name) {
  auto header = ply::parse_header(bytes, name);
  if (!header) {
    if (has_complete_header(bytes)) return header.error();
    return Error{header.message() + " (the file ends at byte offset " + std::to_string(bytes.size()) +
                 ", before a complete 'end_header' line)"};
  }
  const Header& h = *header;
  if (h.format == PlyFormat::Ascii)
    return ply::make_error(name, "a compressed PLY must be binary (its fields are packed bit words), not ascii");

  const Element* chunk = h.find("chunk");
  const Element* vertex = h.find("vertex");
  const Element* sh = h.find("sh");
  if (!chunk || !vertex)
    return ply::make_error(name, std::string("not a compressed PLY: no '") + (chunk ? "vertex" : "chunk") +
                                     "' element (expected elements chunk, vertex and optionally sh)");
  for (const Element& e : h.elements)
    if (&e != chunk && &e != vertex && &e != sh)
      return ply::make_error(name, "unexpected element '" + e.name + "' (header line " + std::to_string(e.header_line) +
                                       "); a compressed PLY has only chunk, vertex and sh");

  ElementLayout chunks, packed, rest;
  auto chunk_slot = [](std::string_view s) {
    for (std::size_t k = 0; k < kChunkProps.size(); ++k)
      if (kChunkProps[k] == s) return static_cast<int>(k);
    return -1;
  };
  auto vertex_slot = [](std::string_view s) {
    for (std::size_t k = 0; k < kVertexProps.size(); ++k)
      if (kVertexProps[k] == s) return static_cast<int>(k);
    return -1;
  };
  auto rest_slot = [](std::string_view s) {
    const int k = rest_index(s);
    return k < kMaxShProps ? k : -1;
  };
  if (Status st = map_element(*chunk, static_cast<int>(kChunkProps.size()), Type::Float32, chunk_slot, name, chunks); !st)
    return st.error();
  if (Status st = map_element(*vertex, static_cast<int>(kVertexProps.size()), Type::UInt32, vertex_slot, name, packed); !st)
    return st.error();
  for (int k = 0; k < kChunkRequired; ++k)
    if (chunks.at[static_cast<std::size_t>(k)] < 0) return ply::make_error(name, missing(*chunk, kChunkProps[static_cast<std::size_t>(k)]));
  int colour_bounds = 0;
  for (std::size_t k = kChunkRequired; k < kChunkProps.size(); ++k) colour_bounds += chunks.at[k] >= 0 ? 1 : 0;
  if (colour_bounds != 0 && colour_bounds != 6)
    for (std::size_t k = kChunkRequired; k < kChunkProps.size(); ++k)
      if (chunks.at[k] < 0)
        return ply::make_error(name, missing(*chunk, kChunkProps[k]) + " (the colour bounds min_r..max_b come as all six or none)");
  const bool has_colour_bounds = colour_bounds == 6;
  for (std::size_t k = 0; k < kVertexProps.size(); ++k)
    if (packed.at[k] < 0) return ply::make_error(name, missing(*vertex, kVertexProps[k]));

  int degree = 0;
  if (sh) {
    if (Status st = map_element(*sh, kMaxShProps, Type::UInt8, rest_slot, name, rest); !st) return st.error();
    const int props = static_cast<int>(sh->properties.size());
    degree = -1;
    for (int d = 1; d <= kMaxShDegree; ++d)
      if (props == 3 * sh_rest_count(d)) degree = d;
    if (degree < 0)
      return ply::make_error(name, "element 'sh' (header line " + std::to_string(sh->header_line) + ") has " +
                                       std::to_string(props) + " properties; expected 9, 24 or 45 (SH degree 1..3)");
    for (int k = 0; k < props; ++k)
      if (rest.at[static_cast<std::size_t>(k)] < 0)
        return ply::make_error(name, missing(*sh, "f_rest_" + std::to_string(k)) + " (it has " + std::to_string(props) +
                                         " f_rest properties, so f_rest_0..f_rest_" + std::to_string(props - 1) +
                                         " must all be present)");
    if (sh->count != vertex->count)
      return ply::make_error(name, "element 'sh' (header line " + std::to_string(sh->header_line) + ") has " +
                                       std::to_string(sh->count) + " items but 'vertex' has " +
                                       std::to_string(vertex->count) + " (one SH record per splat)");
  }
  const std::uint64_t n = vertex->count;
  const std::uint64_t need_chunks = (n + kChunkSplats - 1) / kChunkSplats;
  if (chunk->count != need_chunks)
    return ply::make_error(name, "element 'chunk' (header line " + std::to_string(chunk->header_line) + ") has " +
                                     std::to_string(chunk->count) + " items but " + std::to_string(n) +
                                     " vertices need ceil(" + std::to_string(n) + " / 256) = " +
                                     std::to_string(need_chunks));

  // Element data follows the header in header order; parse_header has checked that the
  // declared items fit in the file, so these sums cannot overflow.
  std::size_t offset = h.data_offset;
  for (const Element& e : h.elements) {
    ElementLayout& layout = &e == chunk ? chunks : &e == vertex ? packed : rest;
    layout.offset = offset;
    offset += static_cast<std::size_t>(e.count) * layout.stride;
  }
  if (offset > bytes.size())
    return ply::make_error(name, "the file ends at byte offset " + std::to_string(bytes.size()) + " but its elements need " +
                                     std::to_string(offset) + " bytes (truncated file or wrong count)");
  if (offset < bytes.size())
    return ply::make_error(name, std::to_string(bytes.size() - offset) +
                                     " bytes of unexpected data after the last element, at byte offset " +
                                     std::to_string(offset));

  const bool swap = ply::needs_swap(h.format == PlyFormat::BinaryBigEndian);
  const std::uint8_t* data = bytes.data();

  // Chunk bounds, checked finite so every decoded value is.
  const std::size_t num_chunks = static_cast<std::size_t>(chunk->count);
  std::vector<std::array<float, kChunkProps.size()>> bounds(num_chunks);
  for (std::size_t c = 0; c < num_chunks; ++c)
    for (std::size_t k = 0; k < kChunkProps.size(); ++k) {
      if (chunks.at[k] < 0) continue;
      const std::size_t at = chunks.offset + c * chunks.stride + static_cast<std::size_t>(chunks.at[k]);
      const float v = ply::load<float>(data + at, swap);
      if (!std::isfinite(v))
        return ply::make_error(name, "chunk " + std::to_string(c) + ", property '" + std::string(kChunkProps[k]) +
                                         "' (byte offset " + std::to_string(at) + "): value is " +
                                         (std::isnan(v) ? "NaN" : v > 0 ? "+Inf" : "-Inf") + " (bounds must be finite)");
      // A colour bound becomes f_dc = (bound - 0.5) / SH_C0, 3.5x larger: keep that a float.
      if (k >= kChunkRequired && std::abs((double(v) - 0.5) / kShC0) > double(std::numeric_limits<float>::max()))
        return ply::make_error(name, "chunk " + std::to_string(c) + ", property '" + std::string(kChunkProps[k]) +
                                         "' (byte offset " + std::to_string(at) + "): colour bound " +
                                         ply::format_double(v) + " gives an f_dc beyond the float range");
      bounds[c][k] = v;
    }

  SplatScene scene;
  scene.report.format = SplatFormat::CompressedPly;
  scene.cloud.sh_degree = degree;
  std::vector<Gaussian>& gs = scene.cloud.gaussians;
  if (auto s = io::resize_cloud(gs, static_cast<std::size_t>(n), name); !s) return s.error();
  const int coefs = sh_rest_count(degree);
  const double sqrt2 = std::sqrt(2.0);
  for (std::size_t i = 0; i < gs.size(); ++i) {
    Gaussian& g = gs[i];
    const auto& b = bounds[i / kChunkSplats];
    const std::uint8_t* item = data + packed.offset + i * packed.stride;
    std::uint32_t word[4];
    for (std::size_t k = 0; k < 4; ++k) word[k] = ply::load<std::uint32_t>(item + packed.at[k], swap);

    const double tp[3] = {unorm(word[0] >> 21, 11), unorm(word[0] >> 11, 10), unorm(word[0], 11)};
    const double ts[3] = {unorm(word[2] >> 21, 11), unorm(word[2] >> 11, 10), unorm(word[2], 11)};
    for (int a = 0; a < 3; ++a) {
      g.position[a] = static_cast<float>(lerp(b[a], b[3 + a], tp[a]));
      g.log_scale[a] = static_cast<float>(lerp(b[6 + a], b[9 + a], ts[a]));
    }

    const std::uint32_t r = word[1];
    g.rotation = io::rebuild_quaternion(static_cast<int>(r >> 30), (unorm(r >> 20, 10) - 0.5) * sqrt2,
                                        (unorm(r >> 10, 10) - 0.5) * sqrt2, (unorm(r, 10) - 0.5) * sqrt2);

    const std::uint32_t col = word[3];
    for (int a = 0; a < 3; ++a) {
      const double t = unorm(col >> (24 - 8 * a), 8);
      const double colour = has_colour_bounds ? lerp(b[12 + a], b[15 + a], t) : t;
      g.sh_dc[a] = static_cast<float>((colour - 0.5) / kShC0);
    }
    g.opacity_logit = io::alpha_to_logit(unorm(col, 8));

    if (coefs > 0) {
      const std::uint8_t* s = data + rest.offset + i * rest.stride;
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < coefs; ++k)
          g.sh_rest[static_cast<std::size_t>(k)][c] = sh_from_byte(s[rest.at[static_cast<std::size_t>(c * coefs + k)]]);
    }
  }
  io::finish_quantized_scene(scene);
  return scene;
}

}  // namespace gauss
