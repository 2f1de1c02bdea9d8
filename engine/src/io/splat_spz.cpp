// Niantic SPZ reader (splat_file.h), versions 2, 3 (gzip) and 4 (NGSP container).
//
// Containers (all integers little-endian):
//   v2, v3  a gzip stream of: 16-byte header {u32 magic "NGSP" 0x5053474e, u32 version,
//           u32 numPoints, u8 shDegree, u8 fractionalBits, u8 flags, u8 reserved}, then the
//           attribute blocks below back to back, then (flags bit 1 only) extension records.
//   v4      not compressed as a whole: 32-byte header {magic, version, numPoints, shDegree,
//           fractionalBits, flags, u8 numStreams, u32 tocByteOffset, 12 reserved bytes};
//           extension records in [32, tocByteOffset) (flags bit 1); at tocByteOffset a table of
//           numStreams entries {u64 compressedSize, u64 uncompressedSize}; then the streams, each
//           one zstd-compressed attribute block, back to back in block order up to the file's
//           end. Empty blocks (SH at degree 0, everything when numPoints is 0) have no stream.
//   flags   bit 0: trained with antialiasing (reported as SplatFileReport::antialiased);
//           bit 1: extension records present; other bits are ignored, as the reference does.
//   Extension record: {u32 type, u32 byteLength, payload}. Only 0xADBE0003 (storage coordinate
//           system, a u32 enum) changes how data decodes; the others are skipped.
//
// Attribute blocks, in file order, with their quantisation (n = numPoints):
//   positions  n x 3 x 24-bit two's complement fixed point; x = int24 / 2^fractionalBits.
//              Step 2^-f (0.244 mm at the writers' f = 12), worst case half that for
//              |x| < 2^(23-f) (2048 m at f = 12). The reference writer wraps larger values.
//   alphas     n x u8 = round(255 sigmoid(opacity)); opacity_logit = logit(clamp(b/255, 0.5/255,
//              1 - 0.5/255)): the clamp keeps 0 and 255 finite (-/+6.2324) and sigmoid(decoded)
//              within 0.5/255 of the source opacity. (The reference decoder clamps to
//              [1/255, 254/255], which breaks that bound at the ends.)
//   colours    n x 3 x u8 = round(255 (0.5 + 0.15 f_dc)) clamped; f_dc = (b/255 - 0.5) / 0.15.
//              0.15 instead of SH_C0 = 0.282 leaves headroom for base colours that the SH
//              bands bring back into range. Step 0.02614, worst case 0.01307 for |f_dc| <= 3.333.
//   scales     n x 3 x u8 = round(16 (log_scale + 10)) clamped; log_scale = b/16 - 10.
//              Step 1/16, worst case 1/32 for log_scale in [-10, 5.9375].
//   rotations  v3, v4: n x u32 "smallest three": bits 31..30 the index (in x, y, z, w order) of
//              the largest |component|, made positive; then for the other three in index order,
//              most significant first, a sign bit and a 9-bit magnitude m, value m/511 * sqrt(1/2);
//              the largest is sqrt(1 - sum of squares of the others). Worst case 6.9e-4 per
//              stored component.
//              v2: n x 3 x u8 (x, y, z of the quaternion made w >= 0), value b/127.5 - 1, and
//              w = sqrt(max(0, 1 - |xyz|^2)). Worst case 0.0039 per stored component; w is badly
//              conditioned near 0 (errors up to ~0.09 there): a known weakness of v2.
//   SH         n x (shDegree+1)^2-1 coefficients x 3 channels (channel fastest), u8,
//              value (b - 128) / 128. Step 1/128; the reference writer also rounds degree 1 to
//              5 bits and degrees 2-3 to 4 bits: worst case 4.5/128 = 0.035 and 8.5/128 = 0.066
//              for |v| < 1. Values outside [-1, 127/128] were clamped by the writer.
// Every decoded value is finite by construction, so NaN/Inf never reach the cloud.
//
// Coordinates: SPZ stores RUB (x right, y up, z back; OpenGL / three.js) unless a
// coordinate-system extension names another system; 3DGS PLY files, and this engine, use RDF
// (y down, z forward). Decoding converts to RDF: positions (x, -y, -z), quaternion vector part
// (x, -y, -z), each SH coefficient times the sign its basis polynomial takes under the flip.
// This is what makes fruit_drops_sh3.v3.spz / .v4.spz (PlayCanvas splat-transform 2.7.1) and
// metalsplatter_3-points-from-train.spz match the PLY files they were made from; without it
// y, z and the odd-in-y/z SH bands come out negated. Storage systems that differ from RDF by
// axis signs only (LDB .. RUF) are converted the same way; those that permute axes are refused.
//
// Errors name the input and, for truncations and impossible values, the byte offset (in the
// file, or in the decompressed gzip stream for v2/v3, which the message says). Limits: SH degree
// at most 3 (SPZ allows 4; the engine's Gaussian stops at 3), fractionalBits at most 24, and for
// v4 numPoints at most fileSize * 1024 / 9 (the reference's zstd-ratio sanity bound), so a tiny
// hostile file cannot claim gigabytes. Never a partial cloud.
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "gauss/engine/splat_file.h"
#include "io/memory_room.h"
#include "io/splat_quantized.h"

namespace gauss {
namespace {

constexpr std::uint32_t kMagic = 0x5053474e;  // "NGSP" read as a little-endian u32
constexpr std::size_t kLegacyHeaderBytes = 16;
constexpr std::size_t kNgspHeaderBytes = 32;
constexpr std::size_t kTocEntryBytes = 16;
constexpr std::size_t kExtensionRecordHeaderBytes = 8;
constexpr int kMaxFractionalBits = 24;  // as the reference: 24-bit integers, no point in more
constexpr std::uint64_t kMaxZstdRatio = 1024;   // reference bound on claimed points per file byte
constexpr std::uint64_t kMinBytesPerPoint = 9;  // the positions block alone
// A gzip stream may inflate ~1000x; past this the input is treated as a decompression bomb.
constexpr std::uint64_t kMaxInflatedBytes = 4ull << 30;
constexpr std::uint8_t kFlagAntialiased = 0x1;
constexpr std::uint8_t kFlagExtensions = 0x2;
constexpr std::uint32_t kExtensionCoordinateSystem = 0xADBE0003u;
constexpr double kColorScale = 0.15;

enum Block : std::size_t { kPositions, kAlphas, kColors, kScales, kRotations, kSh, kBlockCount };
constexpr std::array<const char*, kBlockCount> kBlockNames = {"positions", "alphas",    "colours",
                                                              "scales",    "rotations", "SH"};

Error fail(std::string_view name, const std::string& what) { return Error{std::string(name) + ": " + what}; }

std::uint32_t u32_at(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}
std::uint64_t u64_at(const std::uint8_t* p) { return std::uint64_t(u32_at(p)) | std::uint64_t(u32_at(p + 4)) << 32; }

struct Header {
  std::uint32_t version{0};
  std::uint32_t num_points{0};
  int sh_degree{0};
  int fractional_bits{0};
  std::uint8_t flags{0};
};

// Bytes per point of each block, for this header.
std::array<std::size_t, kBlockCount> bytes_per_point(const Header& h) {
  return {9, 1, 3, 3, h.version >= 3 ? 4u : 3u, 3 * static_cast<std::size_t>(sh_rest_count(h.sh_degree))};
}

// Axis signs taking the storage system to RDF (x right, y down, z forward).
struct AxisSigns {
  int x{1}, y{-1}, z{-1};  // RUB, SPZ's default
};

// Checks the fields both headers share; `where` says whose offsets these are.
Status check_header(const Header& h, std::string_view name, const std::string& where) {
  if (h.sh_degree > kMaxShDegree)
    return fail(name, "SH degree " + std::to_string(h.sh_degree) + " at byte offset 12" + where +
                          " is not supported (at most " + std::to_string(kMaxShDegree) + ")");
  if (h.fractional_bits > kMaxFractionalBits)
    return fail(name, "fractionalBits " + std::to_string(h.fractional_bits) + " at byte offset 13" + where +
                          " exceeds " + std::to_string(kMaxFractionalBits));
  return Ok{};
}

Header read_header(const std::uint8_t* p) {
  Header h;
  h.version = u32_at(p + 4);
  h.num_points = u32_at(p + 8);
  h.sh_degree = p[12];
  h.fractional_bits = p[13];
  h.flags = p[14];
  return h;
}

// Parses extension records filling exactly [begin, end) of `bytes`; offsets are `where`'s.
Status read_extensions(std::span<const std::uint8_t> bytes, std::size_t begin, std::size_t end,
                       std::string_view name, const std::string& where, AxisSigns& signs) {
  std::size_t at = begin;
  while (at < end) {
    if (end - at < kExtensionRecordHeaderBytes)
      return fail(name, "extension record at byte offset " + std::to_string(at) + where + " is cut short: " +
                            std::to_string(end - at) + " of its 8 header bytes before byte offset " +
                            std::to_string(end));
    const std::uint32_t type = u32_at(bytes.data() + at);
    const std::uint32_t length = u32_at(bytes.data() + at + 4);
    const std::size_t payload = at + kExtensionRecordHeaderBytes;
    if (length > end - payload)
      return fail(name, "extension record at byte offset " + std::to_string(at) + where + " declares " +
                            std::to_string(length) + " payload bytes but only " + std::to_string(end - payload) +
                            " remain before byte offset " + std::to_string(end));
    if (type == kExtensionCoordinateSystem) {
      if (length != 4)
        return fail(name, "coordinate-system extension at byte offset " + std::to_string(at) + where + " has " +
                              std::to_string(length) + " payload bytes (expected 4)");
      // The reference's enum: 0 UNSPECIFIED (read as RUB), 1 LDB, 2 RDB, 3 LUB, 4 RUB, 5 LDF,
      // 6 RDF, 7 LUF, 8 RUF; 9..16 permute axes (LBD .. RFU).
      static constexpr std::array<AxisSigns, 9> kSigns = {{{1, -1, -1},
                                                           {-1, 1, -1},
                                                           {1, 1, -1},
                                                           {-1, -1, -1},
                                                           {1, -1, -1},
                                                           {-1, 1, 1},
                                                           {1, 1, 1},
                                                           {-1, -1, 1},
                                                           {1, -1, 1}}};
      const std::uint32_t system = u32_at(bytes.data() + payload);
      if (system >= kSigns.size())
        return fail(name, "coordinate system " + std::to_string(system) + " at byte offset " +
                              std::to_string(payload) + where +
                              (system <= 16 ? " permutes axes, which is not supported (only sign flips of RDF)"
                                            : " is not a known coordinate system"));
      signs = kSigns[system];
    }
    at = payload + length;
  }
  return Ok{};
}

// Sign each SH coefficient (1..15, PLY order) takes when the axes flip by `s`: the product of
// the axis signs over the odd powers of x, y, z in its basis polynomial.
std::array<float, kMaxShRest> sh_signs(const AxisSigns& s) {
  // Parity of (x, y, z) in y, z, x, xy, yz, 3z^2-1, xz, x^2-y^2, y(3x^2-y^2), xyz, y(5z^2-1),
  // z(5z^2-3), x(5z^2-1), z(x^2-y^2), x(x^2-3y^2).
  static constexpr std::array<std::array<int, 3>, kMaxShRest> kParity = {{{0, 1, 0},
                                                                          {0, 0, 1},
                                                                          {1, 0, 0},
                                                                          {1, 1, 0},
                                                                          {0, 1, 1},
                                                                          {0, 0, 0},
                                                                          {1, 0, 1},
                                                                          {0, 0, 0},
                                                                          {0, 1, 0},
                                                                          {1, 1, 1},
                                                                          {0, 1, 0},
                                                                          {0, 0, 1},
                                                                          {1, 0, 0},
                                                                          {0, 0, 1},
                                                                          {1, 0, 0}}};
  std::array<float, kMaxShRest> out{};
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k] = float((kParity[k][0] ? s.x : 1) * (kParity[k][1] ? s.y : 1) * (kParity[k][2] ? s.z : 1));
  return out;
}

// Decodes the six blocks (already checked to hold num_points each) into the scene.
Expected<SplatScene> decode(const Header& h, const std::array<std::span<const std::uint8_t>, kBlockCount>& blocks,
                            const AxisSigns& signs, std::string_view name) {
  SplatScene scene;
  SplatFileReport& report = scene.report;
  report.format = SplatFormat::Spz;
  report.version = h.version;
  report.antialiased = (h.flags & kFlagAntialiased) != 0;
  scene.cloud.sh_degree = h.sh_degree;

  const int rest = sh_rest_count(h.sh_degree);
  const float position_step = 1.0f / float(1u << h.fractional_bits);  // a power of two: exact
  const std::array<float, kMaxShRest> sh_sign = sh_signs(signs);
  const glm::vec3 axis(float(signs.x), float(signs.y), float(signs.z));
  const float vector_sign = float(signs.x * signs.y * signs.z);  // a reflection (det -1) negates it
  const bool smallest_three = h.version >= 3;

  std::vector<Gaussian>& gs = scene.cloud.gaussians;
  if (auto s = io::resize_cloud(gs, h.num_points, name); !s) return s.error();
  for (std::size_t i = 0; i < gs.size(); ++i) {
    Gaussian& g = gs[i];
    const std::uint8_t* p = blocks[kPositions].data() + 9 * i;
    for (int k = 0; k < 3; ++k, p += 3) {
      std::int32_t v = std::int32_t(std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16);
      if (v & 0x800000) v -= 0x1000000;
      g.position[k] = float(v) * position_step * axis[k];
    }
    g.opacity_logit = io::alpha_to_logit(double(blocks[kAlphas][i]) / 255.0);
    for (int k = 0; k < 3; ++k) {
      g.sh_dc[k] = static_cast<float>((double(blocks[kColors][3 * i + k]) / 255.0 - 0.5) / kColorScale);
      g.log_scale[k] = float(blocks[kScales][3 * i + k]) / 16.0f - 10.0f;
    }

    double q[4];  // x, y, z, w: the file's order
    if (smallest_three) {
      std::uint32_t bits = u32_at(blocks[kRotations].data() + 4 * i);
      const unsigned largest = bits >> 30;
      double sum = 0.0;
      for (int c = 3; c >= 0; --c) {
        if (unsigned(c) == largest) continue;
        const double magnitude = double(bits & 0x1FFu) / 511.0 * std::sqrt(0.5);
        q[c] = (bits & 0x200u) ? -magnitude : magnitude;
        sum += q[c] * q[c];
        bits >>= 10;
      }
      q[largest] = std::sqrt(std::max(0.0, 1.0 - sum));
    } else {
      const std::uint8_t* r = blocks[kRotations].data() + 3 * i;
      for (int c = 0; c < 3; ++c) q[c] = double(r[c]) / 127.5 - 1.0;
      q[3] = std::sqrt(std::max(0.0, 1.0 - (q[0] * q[0] + q[1] * q[1] + q[2] * q[2])));
    }
    g.rotation = glm::vec4(float(q[3]), float(q[0] * axis.x * vector_sign), float(q[1] * axis.y * vector_sign),
                           float(q[2] * axis.z * vector_sign));

    const std::uint8_t* sh = blocks[kSh].data() + std::size_t(3 * rest) * i;
    for (int k = 0; k < rest; ++k)
      for (int c = 0; c < 3; ++c)
        g.sh_rest[std::size_t(k)][c] = (float(sh[3 * k + c]) - 128.0f) / 128.0f * sh_sign[std::size_t(k)];
  }
  io::finish_quantized_scene(scene);
  return scene;
}

// RAII for a zlib inflate stream.
struct Inflater {
  z_stream zs{};
  bool ready{false};
  Inflater() { ready = inflateInit2(&zs, 16 + MAX_WBITS) == Z_OK; }
  ~Inflater() {
    if (ready) inflateEnd(&zs);
  }
  Inflater(const Inflater&) = delete;
  Inflater& operator=(const Inflater&) = delete;
};

// Inflates the whole gzip stream; it must end exactly at the end of the file.
Expected<std::vector<std::uint8_t>> gunzip(std::span<const std::uint8_t> bytes, std::string_view name) {
  Inflater in;
  if (!in.ready) return fail(name, "zlib could not start inflating");
  z_stream& zs = in.zs;
  // The gzip trailer's ISIZE (size mod 2^32) is a hint for the first allocation, nothing more.
  std::uint64_t hint = bytes.size() >= 4 ? u32_at(bytes.data() + bytes.size() - 4) : 0;
  hint = std::min<std::uint64_t>({hint, std::uint64_t(bytes.size()) * 1100, kMaxInflatedBytes});
  std::vector<std::uint8_t> out(std::max<std::size_t>(std::size_t(hint), 4096));
  std::size_t produced = 0;
  std::size_t fed = 0;
  while (true) {
    if (zs.avail_in == 0 && fed < bytes.size()) {
      const std::size_t chunk = std::min<std::size_t>(bytes.size() - fed, 1u << 30);
      zs.next_in = const_cast<Bytef*>(bytes.data() + fed);  // zlib's API is not const-correct
      zs.avail_in = static_cast<uInt>(chunk);
      fed += chunk;
    }
    if (produced == out.size()) {
      if (out.size() >= kMaxInflatedBytes)
        return fail(name, "the gzip stream inflates to more than " + std::to_string(kMaxInflatedBytes >> 30) +
                              " GiB (a decompression bomb?)");
      out.resize(std::size_t(std::min<std::uint64_t>(kMaxInflatedBytes, std::uint64_t(out.size()) * 2)));
    }
    const std::size_t room = std::min<std::size_t>(out.size() - produced, 1u << 30);
    zs.next_out = out.data() + produced;
    zs.avail_out = static_cast<uInt>(room);
    const int rc = inflate(&zs, Z_NO_FLUSH);
    produced += room - zs.avail_out;
    if (rc == Z_STREAM_END) break;
    if (rc == Z_OK) continue;
    if (rc == Z_BUF_ERROR && zs.avail_in == 0 && fed == bytes.size())
      return fail(name, "truncated gzip stream: the file ends at byte offset " + std::to_string(bytes.size()) +
                            " before the stream's end (" + std::to_string(produced) + " bytes inflated)");
    if (rc == Z_BUF_ERROR) continue;
    return fail(name, "corrupt gzip stream near byte offset " + std::to_string(zs.total_in) + ": " +
                          (zs.msg ? std::string(zs.msg) : "zlib error " + std::to_string(rc)));
  }
  if (zs.total_in != bytes.size())
    return fail(name, std::to_string(bytes.size() - zs.total_in) + " bytes follow the gzip stream's end at byte offset " +
                          std::to_string(zs.total_in));
  out.resize(produced);
  return out;
}

// Versions 2 and 3: a gzip stream holding the 16-byte header and the blocks.
Expected<SplatScene> parse_legacy(std::span<const std::uint8_t> file, std::string_view name) {
  auto inflated = gunzip(file, name);
  if (!inflated) return inflated.error();
  const std::vector<std::uint8_t>& data = *inflated;
  const std::string where = " of the decompressed stream";
  if (data.size() < kLegacyHeaderBytes)
    return fail(name, "the decompressed stream ends at byte offset " + std::to_string(data.size()) +
                          ", inside the 16-byte SPZ header");
  if (u32_at(data.data()) != kMagic)
    return fail(name, "the gzip stream does not start with the SPZ magic 'NGSP' (byte offset 0" + where + ")");
  const Header h = read_header(data.data());
  if (h.version != 2 && h.version != 3)
    return fail(name, "SPZ version " + std::to_string(h.version) + " at byte offset 4" + where +
                          " is not supported in a gzip stream (versions 2 and 3; version 4 files are not gzip)");
  if (Status st = check_header(h, name, where); !st) return st.error();

  const auto per_point = bytes_per_point(h);
  std::array<std::span<const std::uint8_t>, kBlockCount> blocks;
  std::uint64_t at = kLegacyHeaderBytes;
  for (std::size_t b = 0; b < kBlockCount; ++b) {
    const std::uint64_t size = std::uint64_t(h.num_points) * per_point[b];
    if (size > data.size() - at) {
      std::uint64_t total = 0;
      for (std::size_t p : per_point) total += p;
      return fail(name, "numPoints " + std::to_string(h.num_points) + " (byte offset 8" + where + ") needs " +
                            std::to_string(total * h.num_points) + " bytes of attributes, but the " +
                            kBlockNames[b] + " block starting at byte offset " + std::to_string(at) + where +
                            " runs past the stream's end at byte offset " + std::to_string(data.size()));
    }
    blocks[b] = std::span<const std::uint8_t>(data.data() + at, std::size_t(size));
    at += size;
  }
  AxisSigns signs;
  if (h.flags & kFlagExtensions) {
    if (Status st = read_extensions(data, std::size_t(at), data.size(), name, where, signs); !st) return st.error();
  } else if (at != data.size()) {
    return fail(name, std::to_string(data.size() - at) + " bytes follow the last attribute block (byte offset " +
                          std::to_string(at) + where + ") and the header's flags declare no extensions");
  }
  return decode(h, blocks, signs, name);
}

// Version 4: the NGSP container with one zstd stream per block.
Expected<SplatScene> parse_ngsp(std::span<const std::uint8_t> file, std::string_view name) {
  if (file.size() < kNgspHeaderBytes)
    return fail(name, "the file ends at byte offset " + std::to_string(file.size()) +
                          ", inside the 32-byte SPZ (NGSP) header");
  const Header h = read_header(file.data());
  if (h.version != 4)
    return fail(name, "SPZ version " + std::to_string(h.version) + " at byte offset 4 is not supported in an NGSP " +
                          "container (version 4; versions 2 and 3 are gzip streams)");
  if (Status st = check_header(h, name, ""); !st) return st.error();
  if (std::uint64_t(h.num_points) > std::uint64_t(file.size()) * kMaxZstdRatio / kMinBytesPerPoint)
    return fail(name, "numPoints " + std::to_string(h.num_points) + " at byte offset 8 is impossible for a file of " +
                          std::to_string(file.size()) + " bytes (at most " +
                          std::to_string(std::uint64_t(file.size()) * kMaxZstdRatio / kMinBytesPerPoint) + ")");

  const auto per_point = bytes_per_point(h);
  std::vector<std::size_t> present;  // blocks that have a stream, in order
  for (std::size_t b = 0; b < kBlockCount; ++b)
    if (h.num_points > 0 && per_point[b] > 0) present.push_back(b);
  const std::size_t streams = file[15];
  if (streams != present.size())
    return fail(name, "numStreams " + std::to_string(streams) + " at byte offset 15, expected " +
                          std::to_string(present.size()) + " for " + std::to_string(h.num_points) +
                          " points at SH degree " + std::to_string(h.sh_degree));
  const std::size_t toc = u32_at(file.data() + 16);
  if (toc < kNgspHeaderBytes || toc > file.size())
    return fail(name, "tocByteOffset " + std::to_string(toc) + " at byte offset 16 lies outside [32, " +
                          std::to_string(file.size()) + "]");
  const std::size_t toc_end = toc + streams * kTocEntryBytes;
  if (toc_end > file.size())
    return fail(name, "the table of contents at byte offset " + std::to_string(toc) + " needs " +
                          std::to_string(streams * kTocEntryBytes) + " bytes, but the file ends at byte offset " +
                          std::to_string(file.size()));
  AxisSigns signs;
  if (h.flags & kFlagExtensions) {
    if (Status st = read_extensions(file, kNgspHeaderBytes, toc, name, "", signs); !st) return st.error();
  }

  std::array<std::vector<std::uint8_t>, kBlockCount> storage;
  std::array<std::span<const std::uint8_t>, kBlockCount> blocks;
  std::size_t at = toc_end;
  for (std::size_t s = 0; s < streams; ++s) {
    const std::size_t b = present[s];
    const std::size_t entry = toc + s * kTocEntryBytes;
    const std::uint64_t compressed = u64_at(file.data() + entry);
    const std::uint64_t size = u64_at(file.data() + entry + 8);
    const std::uint64_t expected = std::uint64_t(h.num_points) * per_point[b];
    const std::string stream = "stream " + std::to_string(s) + " (" + kBlockNames[b] + ")";
    if (size != expected)
      return fail(name, stream + ": its table entry at byte offset " + std::to_string(entry) + " gives " +
                            std::to_string(size) + " uncompressed bytes, expected " + std::to_string(expected) +
                            " (numPoints x " + std::to_string(per_point[b]) + ")");
    if (compressed > file.size() - at)
      return fail(name, stream + " at byte offset " + std::to_string(at) + " declares " + std::to_string(compressed) +
                            " compressed bytes but the file ends at byte offset " + std::to_string(file.size()));
    storage[b].resize(std::size_t(expected));
    const std::size_t got = ZSTD_decompress(storage[b].data(), storage[b].size(), file.data() + at, std::size_t(compressed));
    if (ZSTD_isError(got))
      return fail(name, stream + " at byte offset " + std::to_string(at) + ": zstd: " + ZSTD_getErrorName(got));
    if (got != expected)
      return fail(name, stream + " at byte offset " + std::to_string(at) + " decompresses to " + std::to_string(got) +
                            " bytes, expected " + std::to_string(expected));
    blocks[b] = storage[b];
    at += std::size_t(compressed);
  }
  if (at != file.size())
    return fail(name, std::to_string(file.size() - at) + " bytes follow the last stream (byte offset " +
                          std::to_string(at) + ")");
  return decode(h, blocks, signs, name);
}

}  // namespace

Expected<SplatScene> parse_spz(std::span<const std::uint8_t> bytes, std::string_view name) {
  if (bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b) return parse_legacy(bytes, name);
  if (bytes.size() >= 4 && u32_at(bytes.data()) == kMagic) return parse_ngsp(bytes, name);
  if (bytes.empty()) return fail(name, "empty file: no SPZ signature at byte offset 0");
  return fail(name, "not an SPZ file: it starts with neither gzip's 1f 8b nor the magic 'NGSP' (byte offset 0)");
}

}  // namespace gauss
