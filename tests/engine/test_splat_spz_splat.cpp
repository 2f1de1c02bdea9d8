// SPZ (v2, v3, v4) and antimatter15 .splat readers: hand-made files for every field, hostile and
// truncated inputs, and the real files in the shared data against the PLY they were made from
// (printing the largest error per field, which docs record).
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/splat_file.h"
#include "opacity.h"
#include "test_data.h"

namespace gauss {
namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr double kLn509 = 6.2324480165505225;  // logit(1 - 0.5/255): where 8-bit alphas 0 and 255 land

void put_u32(Bytes& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(std::uint8_t(v >> (8 * k)));
}
void put_u64(Bytes& out, std::uint64_t v) {
  put_u32(out, std::uint32_t(v));
  put_u32(out, std::uint32_t(v >> 32));
}
void put_f32(Bytes& out, float f) {
  std::uint8_t b[4];
  std::memcpy(b, &f, 4);
  out.insert(out.end(), b, b + 4);
}

Bytes operator+(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

double logit(double a) { return std::log(a / (1.0 - a)); }

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// ---- .splat ------------------------------------------------------------------------------

struct SplatRecord {
  float position[3];
  float scale[3];
  std::uint8_t rgba[4];
  std::uint8_t rotation[4];  // w x y z
};

Bytes encode_splat(const std::vector<SplatRecord>& records) {
  Bytes out;
  for (const auto& r : records) {
    for (float p : r.position) put_f32(out, p);
    for (float s : r.scale) put_f32(out, s);
    out.insert(out.end(), r.rgba, r.rgba + 4);
    out.insert(out.end(), r.rotation, r.rotation + 4);
  }
  return out;
}

std::vector<SplatRecord> three_splats() {
  return {{{1.5f, -2.25f, 3.0f}, {0.01f, 0.5f, 2.0f}, {0, 128, 255, 0}, {255, 128, 128, 128}},
          {{-0.0f, 1e-30f, -1e30f}, {1e-20f, 1.0f, 3e4f}, {200, 10, 77, 255}, {128, 128, 128, 128}},
          {{7.0f, 8.0f, 9.0f}, {1.0f, 1.0f, 1.0f}, {1, 2, 3, 128}, {100, 150, 60, 200}}};
}

// ---- SPZ -----------------------------------------------------------------------------------

struct SpzPoint {
  std::array<std::int32_t, 3> position{};  // 24-bit fixed point
  std::uint8_t alpha{128};
  std::array<std::uint8_t, 3> color{128, 128, 128};
  std::array<std::uint8_t, 3> scale{160, 160, 160};
  std::array<std::uint8_t, 4> rotation{0, 0, 0, 0xC0};  // v3/v4: smallest three (identity); v2 uses 3
  std::vector<std::uint8_t> sh;                         // 3 * sh_rest_count(degree), channel fastest
};

struct SpzFile {
  std::uint32_t version{3};
  int degree{0};
  int fractional_bits{12};
  std::uint8_t flags{0};
  std::vector<SpzPoint> points;
  Bytes extensions;  // raw records (v2/v3: after the blocks; v4: between header and TOC)
};

std::array<Bytes, 6> blocks_of(const SpzFile& f) {
  std::array<Bytes, 6> b;
  for (const auto& p : f.points) {
    for (std::int32_t v : p.position)
      for (int k = 0; k < 3; ++k) b[0].push_back(std::uint8_t(std::uint32_t(v) >> (8 * k)));
    b[1].push_back(p.alpha);
    b[2].insert(b[2].end(), p.color.begin(), p.color.end());
    b[3].insert(b[3].end(), p.scale.begin(), p.scale.end());
    b[4].insert(b[4].end(), p.rotation.begin(), p.rotation.begin() + (f.version == 2 ? 3 : 4));
    b[5].insert(b[5].end(), p.sh.begin(), p.sh.end());
  }
  return b;
}

Bytes gzip(const Bytes& raw) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 9, Z_DEFLATED, 16 + MAX_WBITS, 9, Z_DEFAULT_STRATEGY), Z_OK);
  Bytes out(deflateBound(&zs, uLong(raw.size())) + 64);
  zs.next_in = const_cast<Bytef*>(raw.data());
  zs.avail_in = uInt(raw.size());
  zs.next_out = out.data();
  zs.avail_out = uInt(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

Bytes zstd(const Bytes& raw) {
  Bytes out(ZSTD_compressBound(raw.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
  EXPECT_FALSE(ZSTD_isError(n));
  out.resize(n);
  return out;
}

Bytes header_fields(const SpzFile& f) {
  Bytes h;
  put_u32(h, 0x5053474e);
  put_u32(h, f.version);
  put_u32(h, std::uint32_t(f.points.size()));
  h.push_back(std::uint8_t(f.degree));
  h.push_back(std::uint8_t(f.fractional_bits));
  h.push_back(f.flags);
  return h;  // 15 bytes: the 16th differs between the containers
}

// The uncompressed v2/v3 payload (what the gzip stream holds).
Bytes legacy_payload(const SpzFile& f) {
  Bytes out = header_fields(f);
  out.push_back(0);  // reserved
  for (const Bytes& b : blocks_of(f)) out.insert(out.end(), b.begin(), b.end());
  out.insert(out.end(), f.extensions.begin(), f.extensions.end());
  return out;
}

Bytes encode_spz(const SpzFile& f) {
  if (f.version < 4) return gzip(legacy_payload(f));
  std::vector<Bytes> streams;
  std::vector<std::size_t> sizes;
  for (const Bytes& b : blocks_of(f))
    if (!b.empty()) {
      streams.push_back(zstd(b));
      sizes.push_back(b.size());
    }
  Bytes out = header_fields(f);
  out.push_back(std::uint8_t(streams.size()));
  put_u32(out, std::uint32_t(32 + f.extensions.size()));
  out.insert(out.end(), 12, std::uint8_t{0});
  out.insert(out.end(), f.extensions.begin(), f.extensions.end());
  for (std::size_t s = 0; s < streams.size(); ++s) {
    put_u64(out, streams[s].size());
    put_u64(out, sizes[s]);
  }
  for (const Bytes& s : streams) out.insert(out.end(), s.begin(), s.end());
  return out;
}

Bytes extension_record(std::uint32_t type, const Bytes& payload) {
  Bytes r;
  put_u32(r, type);
  put_u32(r, std::uint32_t(payload.size()));
  r.insert(r.end(), payload.begin(), payload.end());
  return r;
}
Bytes coordinate_system_record(std::uint32_t system) {
  Bytes p;
  put_u32(p, system);
  return extension_record(0xADBE0003u, p);
}

// Smallest-three packing written from the format description (x y z w order in the file).
std::array<std::uint8_t, 4> pack_smallest_three(std::array<double, 4> q) {
  int largest = 0;
  for (int i = 1; i < 4; ++i)
    if (std::abs(q[i]) > std::abs(q[largest])) largest = i;
  const bool negate = q[largest] < 0;
  std::uint32_t comp = std::uint32_t(largest);
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const std::uint32_t sign = (q[i] < 0) != negate ? 1u : 0u;
    const std::uint32_t mag = std::uint32_t(std::lround(511.0 * std::abs(q[i]) / std::sqrt(0.5)));
    comp = comp << 10 | sign << 9 | mag;
  }
  return {std::uint8_t(comp), std::uint8_t(comp >> 8), std::uint8_t(comp >> 16), std::uint8_t(comp >> 24)};
}

// The RUB -> RDF sign of SH coefficients 1..15 (odd powers of y and z flip).
constexpr std::array<float, 15> kRubShSign = {-1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};

std::vector<std::uint8_t> sh_pattern(int degree, std::size_t point) {
  std::vector<std::uint8_t> sh(std::size_t(3 * sh_rest_count(degree)));
  for (std::size_t j = 0; j < sh.size(); ++j) sh[j] = std::uint8_t((j * 37 + point * 101 + 5) % 256);
  return sh;
}

SpzFile small_spz(std::uint32_t version, int degree, std::size_t n = 3) {
  SpzFile f;
  f.version = version;
  f.degree = degree;
  for (std::size_t i = 0; i < n; ++i) {
    SpzPoint p;
    p.position = {std::int32_t(4096 * i + 17), -std::int32_t(100 * i), 0x7FFFFF - std::int32_t(i)};
    p.alpha = std::uint8_t(40 * i + 3);
    p.color = {std::uint8_t(i), std::uint8_t(100 + i), std::uint8_t(250 - i)};
    p.scale = {std::uint8_t(10 * i), std::uint8_t(128), std::uint8_t(255 - i)};
    if (version == 2)
      p.rotation = {std::uint8_t(128 + 20 * i), 90, 140, 0};
    else
      p.rotation = pack_smallest_three({0.1 * double(i), -0.5, 0.3, 0.8});
    p.sh = sh_pattern(degree, i);
    f.points.push_back(p);
  }
  return f;
}

Expected<SplatScene> parse(const Bytes& b, const char* name = "hand.spz") { return parse_splat_file(b, name); }

// ---- geometry used to check conversions independently of the reader's tables ----------------

using Mat3 = std::array<std::array<double, 3>, 3>;
Mat3 rotation_matrix(const glm::vec4& q) {  // q = (w, x, y, z), unit
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

// The 3DGS real SH basis (degrees 1..3) at unit direction d, coefficient k+1 in slot k.
std::array<double, 15> sh_basis(double x, double y, double z) {
  const double c1 = 0.4886025119029199;
  const double c2[] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                       0.5462742152960396};
  const double c3[] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                       -0.4570457994644658, 1.445305721320277,  -0.5900435899266435};
  const double xx = x * x, yy = y * y, zz = z * z;
  return {-c1 * y,
          c1 * z,
          -c1 * x,
          c2[0] * x * y,
          c2[1] * y * z,
          c2[2] * (2 * zz - xx - yy),
          c2[3] * x * z,
          c2[4] * (xx - yy),
          c3[0] * y * (3 * xx - yy),
          c3[1] * x * y * z,
          c3[2] * y * (4 * zz - xx - yy),
          c3[3] * z * (2 * zz - 3 * xx - 3 * yy),
          c3[4] * x * (4 * zz - xx - yy),
          c3[5] * z * (xx - yy),
          c3[6] * x * (xx - 3 * yy)};
}

// ==== .splat ================================================================================

TEST(AntimatterSplat, EveryFieldDecodes) {
  const auto records = three_splats();
  auto s = parse_splat_file(encode_splat(records), "hand.splat");
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->report.format, SplatFormat::AntimatterSplat);
  EXPECT_EQ(s->report.count, 3u);
  EXPECT_EQ(s->report.sh_degree, 0);
  EXPECT_EQ(s->cloud.sh_degree, 0);
  EXPECT_FALSE(s->report.has_gaussian_id);
  EXPECT_FALSE(s->report.has_object_id);
  EXPECT_EQ(s->report.zero_quaternions, 1u);          // record 1: all four bytes 128
  EXPECT_EQ(s->report.renormalized_quaternions, 2u);  // the other two decode non-unit
  ASSERT_EQ(s->cloud.gaussians.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const Gaussian& g = s->cloud.gaussians[i];
    const SplatRecord& r = records[i];
    EXPECT_EQ(g.id, GaussianId{i});
    EXPECT_EQ(g.object, kNoObject);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(g.position[k], r.position[k]);
      EXPECT_NEAR(g.log_scale[k], std::log(double(r.scale[k])), 1e-5);
      EXPECT_NEAR(g.sh_dc[k], (r.rgba[k] / 255.0 - 0.5) / kShC0, 1e-6);
    }
    for (const auto& rest : g.sh_rest) EXPECT_EQ(rest, glm::vec3(0.0f));
  }
  // Alpha 0 and 255 are clamped to 0.5/255 from the ends: finite logits -/+ln(509).
  EXPECT_NEAR(s->cloud.gaussians[0].opacity_logit, -kLn509, 1e-5);
  EXPECT_NEAR(s->cloud.gaussians[1].opacity_logit, kLn509, 1e-5);
  EXPECT_NEAR(s->cloud.gaussians[2].opacity_logit, logit(128.0 / 255.0), 1e-6);
  // Rotations: (b - 128) / 128 normalised, w first; the zero quaternion became the identity.
  EXPECT_EQ(s->cloud.gaussians[0].rotation, glm::vec4(1, 0, 0, 0));
  EXPECT_EQ(s->cloud.gaussians[1].rotation, glm::vec4(1, 0, 0, 0));
  const double q[4] = {-28.0 / 128, 22.0 / 128, -68.0 / 128, 72.0 / 128};
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(s->cloud.gaussians[2].rotation[k], q[k] / n, 1e-6);
}

TEST(AntimatterSplat, MalformedInputsNameTheByteOffset) {
  struct Case {
    const char* label;
    Bytes bytes;
    std::vector<std::string> fragments;
  };
  auto with = [](auto edit) {
    auto r = three_splats();
    edit(r);
    return encode_splat(r);
  };
  std::vector<Case> cases = {
      {"empty", {}, {"bad.splat: ", "empty file", "byte offset 0"}},
      {"partial_record", Bytes(70, 0), {"truncated record at byte offset 64", "6 of 32 bytes"}},
      {"every_record_unusable", with([](auto& r) {
         r[0].position[1] = std::nanf("");
         r[1].scale[2] = 0.0f;
         r[2].position[0] = INFINITY;
       }),
       {"every one of its 3 records is unusable", "the first: splat 0: non-finite position at byte offset 4"}},
  };
  for (const auto& c : cases) {
    auto s = parse_antimatter_splat(c.bytes, "bad.splat");
    ASSERT_FALSE(s.ok()) << c.label;
    for (const auto& f : c.fragments) EXPECT_TRUE(has(s.message(), f)) << c.label << ": " << s.message();
  }
  // A record that cannot be a Gaussian is left out, named by its byte offset; the others keep
  // their record index as id (a labels file stays aligned through report.dropped).
  struct Bad {
    const char* label;
    std::size_t record;
    std::function<void(SplatRecord&)> edit;
    std::string fragment;
  };
  const std::vector<Bad> bad = {
      {"nan_position", 1, [](SplatRecord& r) { r.position[2] = std::nanf(""); }, "splat 1: non-finite position at byte offset 40"},
      {"inf_position", 2, [](SplatRecord& r) { r.position[0] = INFINITY; }, "splat 2: non-finite position at byte offset 64"},
      {"zero_scale", 0, [](SplatRecord& r) { r.scale[1] = 0.0f; }, "splat 0: scale 0 at byte offset 16 is not positive"},
      {"negative_scale", 2, [](SplatRecord& r) { r.scale[2] = -1.0f; }, "splat 2: scale -1 at byte offset 84"},
      {"nan_scale", 1, [](SplatRecord& r) { r.scale[0] = std::nanf(""); }, "splat 1: scale nan at byte offset 44"},
      {"inf_scale", 1, [](SplatRecord& r) { r.scale[0] = INFINITY; }, "byte offset 44"},
  };
  for (const Bad& b : bad) {
    auto records = three_splats();
    b.edit(records[b.record]);
    auto s = parse_antimatter_splat(encode_splat(records), "bad.splat");
    ASSERT_TRUE(s.ok()) << b.label << ": " << s.message();
    EXPECT_EQ(s->report.count, 2u) << b.label;
    ASSERT_EQ(s->report.dropped, std::vector<std::size_t>{b.record}) << b.label;
    EXPECT_TRUE(has(s->report.first_dropped, b.fragment)) << b.label << ": " << s->report.first_dropped;
    ASSERT_EQ(s->cloud.gaussians.size(), 2u);
    std::vector<GaussianId> ids;
    for (const Gaussian& g : s->cloud.gaussians) {
      ids.push_back(g.id);
      const SplatRecord& r = records[to_underlying(g.id)];
      for (int k = 0; k < 3; ++k) EXPECT_EQ(g.position[k], r.position[k]) << b.label;
    }
    std::vector<GaussianId> want;
    for (std::size_t i = 0; i < 3; ++i)
      if (i != b.record) want.push_back(GaussianId{i});
    EXPECT_EQ(ids, want) << b.label;
  }
  // Through the dispatcher, a .splat whose size is not whole records is refused by detection.
  auto s = parse_splat_file(Bytes(33, 0), "bad.splat");
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.message(), "bad.splat: ")) << s.message();
}

// ==== SPZ: hand-made files ==================================================================

// Checks a decoded cloud against the bytes it came from (RUB storage, decoded into RDF).
void expect_decodes(const SpzFile& f, const SplatScene& s) {
  ASSERT_EQ(s.cloud.gaussians.size(), f.points.size());
  EXPECT_EQ(s.report.format, SplatFormat::Spz);
  EXPECT_EQ(s.report.version, f.version);
  EXPECT_EQ(s.report.count, f.points.size());
  EXPECT_EQ(s.report.sh_degree, f.degree);
  EXPECT_EQ(s.cloud.sh_degree, f.degree);
  EXPECT_EQ(s.report.antialiased, (f.flags & 1) != 0);
  EXPECT_FALSE(s.report.has_gaussian_id);
  const double step = std::ldexp(1.0, -f.fractional_bits);
  const double axis[3] = {1, -1, -1};
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const SpzPoint& p = f.points[i];
    const Gaussian& g = s.cloud.gaussians[i];
    EXPECT_EQ(g.id, GaussianId{i});
    EXPECT_EQ(g.object, kNoObject);
    for (int k = 0; k < 3; ++k) {
      std::int32_t v = p.position[k] & 0xFFFFFF;
      if (v & 0x800000) v -= 0x1000000;
      EXPECT_EQ(double(g.position[k]), axis[k] * v * step) << "point " << i << " axis " << k;
      EXPECT_NEAR(g.sh_dc[k], (p.color[k] / 255.0 - 0.5) / 0.15, 1e-6);
      EXPECT_EQ(g.log_scale[k], p.scale[k] / 16.0f - 10.0f);
    }
    const double a = std::clamp(p.alpha / 255.0, 0.5 / 255, 1 - 0.5 / 255);
    EXPECT_NEAR(g.opacity_logit, logit(a), 1e-5);
    const int rest = sh_rest_count(f.degree);
    for (int k = 0; k < kMaxShRest; ++k)
      for (int c = 0; c < 3; ++c) {
        const double want = k < rest ? (p.sh[std::size_t(3 * k + c)] - 128) / 128.0 * kRubShSign[std::size_t(k)] : 0.0;
        EXPECT_EQ(double(g.sh_rest[std::size_t(k)][c]), want) << "point " << i << " coefficient " << k + 1;
      }
    const glm::vec4 q = g.rotation;
    EXPECT_NEAR(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3], 1.0, 1e-6);
  }
}

TEST(Spz, EveryFieldEachVersionAndShDegree) {
  for (std::uint32_t version : {2u, 3u, 4u})
    for (int degree = 0; degree <= 3; ++degree) {
      SCOPED_TRACE("version " + std::to_string(version) + " degree " + std::to_string(degree));
      SpzFile f = small_spz(version, degree, 5);
      f.points[0].alpha = 0;
      f.points[1].alpha = 255;
      f.points[2].position = {-0x800000, 0x7FFFFF, -1};  // the 24-bit extremes
      auto s = parse(encode_spz(f));
      ASSERT_TRUE(s.ok()) << s.message();
      expect_decodes(f, *s);
      EXPECT_NEAR(s->cloud.gaussians[0].opacity_logit, -kLn509, 1e-5);
      EXPECT_NEAR(s->cloud.gaussians[1].opacity_logit, kLn509, 1e-5);
    }
}

TEST(Spz, FractionalBitsAndAntialiasFlag) {
  for (int bits : {0, 1, 12, 24}) {
    SpzFile f = small_spz(3, 1);
    f.fractional_bits = bits;
    f.flags = bits == 12 ? 0 : 1;  // antialiased
    auto s = parse(encode_spz(f));
    ASSERT_TRUE(s.ok()) << s.message();
    expect_decodes(f, *s);
    EXPECT_EQ(s->report.antialiased, bits != 12);
  }
  SpzFile f = small_spz(4, 0);
  f.flags = 1 | 0x80;  // unknown flag bits are ignored, as the reference does
  auto s = parse(encode_spz(f));
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_TRUE(s->report.antialiased);
}

TEST(Spz, V2RotationsDeriveW) {
  SpzFile f = small_spz(2, 0, 4);
  // x y z bytes: b / 127.5 - 1 (file order x y z), w = sqrt(1 - |xyz|^2), then RUB -> RDF.
  f.points[0].rotation = {128, 128, 128, 0};  // ~identity
  f.points[1].rotation = {255, 128, 128, 0};  // x = 1: w = 0 (and |q| slightly > 1: renormalised)
  f.points[2].rotation = {200, 60, 150, 0};
  f.points[3].rotation = {0, 0, 0, 0};  // |xyz| > 1: w clamps to 0, renormalised
  auto s = parse(encode_spz(f));
  ASSERT_TRUE(s.ok()) << s.message();
  for (std::size_t i = 0; i < 4; ++i) {
    const auto& r = f.points[i].rotation;
    double x = r[0] / 127.5 - 1, y = r[1] / 127.5 - 1, z = r[2] / 127.5 - 1;
    double w = std::sqrt(std::max(0.0, 1 - (x * x + y * y + z * z)));
    const double n = std::sqrt(w * w + x * x + y * y + z * z);
    const glm::vec4 q = s->cloud.gaussians[i].rotation;
    EXPECT_NEAR(q[0], w / n, 1e-6) << i;
    EXPECT_NEAR(q[1], x / n, 1e-6) << i;
    EXPECT_NEAR(q[2], -y / n, 1e-6) << i;
    EXPECT_NEAR(q[3], -z / n, 1e-6) << i;
  }
  EXPECT_GE(s->report.renormalized_quaternions, 2u);
  EXPECT_EQ(s->report.zero_quaternions, 0u);
}

TEST(Spz, V3SmallestThreeRotationsRoundTrip) {
  // Quaternions in RDF (w x y z) with each component the largest in turn, both signs.
  const std::vector<std::array<double, 4>> rdf = {{0.9, 0.1, -0.3, 0.2},  {0.1, -0.95, 0.2, 0.1},
                                                  {-0.2, 0.1, 0.9, -0.3}, {0.3, 0.2, 0.1, -0.9},
                                                  {1, 0, 0, 0},           {0.5, 0.5, 0.5, 0.5}};
  SpzFile f = small_spz(3, 0, rdf.size());
  for (std::size_t i = 0; i < rdf.size(); ++i) {
    const auto& q = rdf[i];
    const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    f.points[i].rotation = pack_smallest_three({q[1] / n, -q[2] / n, -q[3] / n, q[0] / n});  // RUB, x y z w
  }
  for (std::uint32_t version : {3u, 4u}) {
    f.version = version;
    auto s = parse(encode_spz(f));
    ASSERT_TRUE(s.ok()) << s.message();
    for (std::size_t i = 0; i < rdf.size(); ++i) {
      const auto& q = rdf[i];
      const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      const glm::vec4 got = s->cloud.gaussians[i].rotation;
      double same = 0, flipped = 0;
      for (int k = 0; k < 4; ++k) {
        same = std::max(same, std::abs(got[k] - q[k] / n));
        flipped = std::max(flipped, std::abs(got[k] + q[k] / n));
      }
      EXPECT_LT(std::min(same, flipped), 1.5e-3) << "quaternion " << i;  // 6.9e-4 per stored component
    }
  }
  // Bits 31..30 = 3 (w largest), the others zero: exactly the identity.
  f.points[0].rotation = {0, 0, 0, 0xC0};
  auto s = parse(encode_spz(f));
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->cloud.gaussians[0].rotation, glm::vec4(1, 0, 0, 0));
}

TEST(Spz, V3AndV4OfTheSameDataDecodeIdentically) {
  for (int degree = 0; degree <= 3; ++degree) {
    SpzFile f = small_spz(3, degree, 7);
    f.flags = 1;
    auto v3 = parse(encode_spz(f));
    f.version = 4;
    auto v4 = parse(encode_spz(f));
    ASSERT_TRUE(v3.ok() && v4.ok()) << v3.message() << v4.message();
    ASSERT_EQ(v3->cloud.gaussians.size(), v4->cloud.gaussians.size());
    for (std::size_t i = 0; i < v3->cloud.gaussians.size(); ++i)
      EXPECT_TRUE(same_value(v3->cloud.gaussians[i], v4->cloud.gaussians[i])) << i;
  }
}

TEST(Spz, EmptyCloudsInBothContainers) {
  for (std::uint32_t version : {2u, 3u, 4u}) {
    SpzFile f;
    f.version = version;
    f.degree = 2;
    auto s = parse(encode_spz(f));
    ASSERT_TRUE(s.ok()) << version << ": " << s.message();
    EXPECT_TRUE(s->cloud.gaussians.empty());
    EXPECT_EQ(s->report.sh_degree, 2);
  }
}

// A storage coordinate system other than RUB (the Adobe extension) must decode to the same
// geometry: checked with rotation matrices and the SH basis, not the reader's sign tables.
TEST(Spz, CoordinateSystemExtensionConvertsSignFlippedSystems) {
  // 0 UNSPECIFIED (= RUB), then LDB RDB LUB RUB LDF RDF LUF RUF; signs take storage to RDF.
  const int signs[9][3] = {{1, -1, -1}, {-1, 1, -1}, {1, 1, -1},  {-1, -1, -1}, {1, -1, -1},
                           {-1, 1, 1},  {1, 1, 1},   {-1, -1, 1}, {1, -1, 1}};
  for (std::uint32_t version : {3u, 4u}) {
    SpzFile raw = small_spz(version, 3, 4);
    raw.flags = 2;
    raw.extensions = coordinate_system_record(6);  // RDF: the stored values, unconverted
    auto base = parse(encode_spz(raw));
    ASSERT_TRUE(base.ok()) << base.message();
    for (std::uint32_t system = 0; system <= 8; ++system) {
      SCOPED_TRACE("version " + std::to_string(version) + " system " + std::to_string(system));
      SpzFile f = raw;
      f.extensions = extension_record(0x12340001u, {1, 2, 3}) + coordinate_system_record(system);
      auto s = parse(encode_spz(f));
      ASSERT_TRUE(s.ok()) << s.message();
      const double m[3] = {double(signs[system][0]), double(signs[system][1]), double(signs[system][2])};
      for (std::size_t i = 0; i < f.points.size(); ++i) {
        const Gaussian& a = s->cloud.gaussians[i];
        const Gaussian& b = base->cloud.gaussians[i];
        for (int k = 0; k < 3; ++k) EXPECT_EQ(double(a.position[k]), m[k] * b.position[k]);
        const Mat3 ra = rotation_matrix(a.rotation), rb = rotation_matrix(b.rotation);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) EXPECT_NEAR(ra[r][c], m[r] * rb[r][c] * m[c], 1e-6);
        for (const auto& d : {std::array<double, 3>{0.48, -0.6, 0.64}, std::array<double, 3>{-0.36, 0.8, 0.48}})
          for (int c = 0; c < 3; ++c) {
            const auto ya = sh_basis(m[0] * d[0], m[1] * d[1], m[2] * d[2]), yb = sh_basis(d[0], d[1], d[2]);
            double fa = 0, fb = 0;
            for (int k = 0; k < 15; ++k) {
              fa += a.sh_rest[std::size_t(k)][c] * ya[std::size_t(k)];
              fb += b.sh_rest[std::size_t(k)][c] * yb[std::size_t(k)];
            }
            EXPECT_NEAR(fa, fb, 1e-5);
          }
      }
    }
  }
}

TEST(Spz, ExtensionRecordsAreSkippedOrRefused) {
  SpzFile f = small_spz(3, 1);
  f.flags = 2;
  f.extensions = extension_record(0xABCD0001u, {9, 9, 9, 9, 9});
  auto s = parse(encode_spz(f));
  ASSERT_TRUE(s.ok()) << s.message();
  expect_decodes(f, *s);  // unknown records change nothing

  f.extensions = coordinate_system_record(9);  // LBD: permutes axes
  s = parse(encode_spz(f));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.message(), "coordinate system 9 at byte offset")) << s.message();
  EXPECT_TRUE(has(s.message(), "permutes axes")) << s.message();

  f.extensions = coordinate_system_record(17);
  f.version = 4;
  s = parse(encode_spz(f));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.message(), "coordinate system 17 at byte offset 40")) << s.message();

  f.extensions = extension_record(0xABCD0001u, {1, 2, 3});
  f.extensions.pop_back();  // the record claims 3 payload bytes, 2 remain
  s = parse(encode_spz(f));
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.message(), "extension record at byte offset 32")) << s.message();
}

// Patches a legacy payload (uncompressed) and gzips it.
Bytes legacy_with(const SpzFile& f, std::size_t at, std::uint32_t value, int width) {
  Bytes raw = legacy_payload(f);
  for (int k = 0; k < width; ++k) raw[at + std::size_t(k)] = std::uint8_t(value >> (8 * k));
  return gzip(raw);
}
Bytes ngsp_with(const SpzFile& f, std::size_t at, std::uint64_t value, int width) {
  Bytes b = encode_spz(f);
  for (int k = 0; k < width; ++k) b[at + std::size_t(k)] = std::uint8_t(value >> (8 * k));
  return b;
}

TEST(Spz, MalformedInputsNameTheInputAndByteOffset) {
  const SpzFile v3 = small_spz(3, 1);
  SpzFile v4 = small_spz(4, 1);
  const Bytes good4 = encode_spz(v4);
  const std::size_t toc = 32, first_stream = toc + 6 * 16;  // degree 1: 6 streams
  struct Case {
    const char* label;
    Bytes bytes;
    std::vector<std::string> fragments;
  };
  Bytes trailing4 = good4;
  trailing4.push_back(0);
  Bytes corrupt4 = good4;
  corrupt4[first_stream + 2] ^= 0xFF;  // the first zstd frame's magic
  Bytes gz_trailing = encode_spz(v3);
  gz_trailing.push_back(7);
  Bytes gz_corrupt = encode_spz(v3);
  gz_corrupt[12] ^= 0xFF;
  std::vector<Case> cases = {
      {"not_spz", Bytes{'N', 'G', 'S', 'X'}, {"not an SPZ file", "byte offset 0"}},
      {"empty", {}, {"empty file", "byte offset 0"}},
      {"gzip_bad_magic", gzip(Bytes(40, 'A')), {"magic", "byte offset 0 of the decompressed stream"}},
      {"gzip_short_header", gzip(Bytes{'N', 'G', 'S', 'P', 3, 0}), {"byte offset 6", "16-byte SPZ header"}},
      {"gzip_version_1", legacy_with(v3, 4, 1, 4), {"SPZ version 1 at byte offset 4"}},
      {"gzip_version_4", legacy_with(v3, 4, 4, 4), {"SPZ version 4 at byte offset 4"}},
      {"gzip_sh_degree_4", legacy_with(v3, 12, 4, 1), {"SH degree 4 at byte offset 12"}},
      {"gzip_fractional_bits", legacy_with(v3, 13, 25, 1), {"fractionalBits 25 at byte offset 13"}},
      {"gzip_too_many_points", legacy_with(v3, 8, 4, 4),
       {"numPoints 4 (byte offset 8", "SH block starting at byte offset 96"}},
      {"gzip_absurd_points", legacy_with(v3, 8, 0xFFFFFFFFu, 4), {"numPoints 4294967295"}},
      {"gzip_trailing_payload", gzip(legacy_payload(v3) + Bytes{1, 2}),
       {"2 bytes follow the last attribute block", "byte offset"}},
      {"gzip_trailing_file", gz_trailing, {"1 bytes follow the gzip stream's end at byte offset"}},
      {"gzip_corrupt", gz_corrupt, {"corrupt gzip stream near byte offset"}},
      {"ngsp_short_header", Bytes(good4.begin(), good4.begin() + 20), {"byte offset 20", "32-byte"}},
      {"ngsp_version_3", ngsp_with(v4, 4, 3, 4), {"SPZ version 3 at byte offset 4"}},
      {"ngsp_version_5", ngsp_with(v4, 4, 5, 4), {"SPZ version 5 at byte offset 4"}},
      {"ngsp_sh_degree_4", ngsp_with(v4, 12, 4, 1), {"SH degree 4 at byte offset 12"}},
      {"ngsp_absurd_points", ngsp_with(v4, 8, 0xFFFFFFFFu, 4), {"numPoints 4294967295 at byte offset 8"}},
      {"ngsp_stream_count", ngsp_with(v4, 15, 5, 1), {"numStreams 5 at byte offset 15", "expected 6"}},
      {"ngsp_toc_offset_low", ngsp_with(v4, 16, 8, 4), {"tocByteOffset 8 at byte offset 16"}},
      {"ngsp_toc_offset_high", ngsp_with(v4, 16, 1u << 30, 4), {"at byte offset 16"}},
      {"ngsp_uncompressed_size", ngsp_with(v4, toc + 8, 10, 8),
       {"stream 0 (positions)", "table entry at byte offset 32", "expected 27"}},
      {"ngsp_compressed_size", ngsp_with(v4, toc + 16, 1u << 20, 8),
       {"stream 1 (alphas) at byte offset", "declares 1048576 compressed bytes"}},
      {"ngsp_corrupt_stream", corrupt4, {"zstd:", "at byte offset"}},
      {"ngsp_trailing", trailing4, {"1 bytes follow the last stream"}},
  };
  for (const auto& c : cases) {
    for (const char* name : {"bad.spz", "bad.splat"}) {  // content decides, not the extension
      auto s = parse_spz(c.bytes, name);
      ASSERT_FALSE(s.ok()) << c.label;
      EXPECT_EQ(s.message().rfind(std::string(name) + ": ", 0), 0u) << c.label << ": " << s.message();
      for (const auto& f : c.fragments) EXPECT_TRUE(has(s.message(), f)) << c.label << ": " << s.message();
    }
  }
}

// Every proper prefix of a small valid file is an error naming a byte offset (a .splat prefix
// of whole records is itself a valid, smaller file, so those are skipped).
TEST(SplatFileTruncation, EveryPrefixIsAnErrorWithAnOffset) {
  struct Valid {
    const char* name;
    Bytes bytes;
  };
  SpzFile v4 = small_spz(4, 2);
  v4.flags = 3;
  v4.extensions = coordinate_system_record(4);
  SpzFile v3 = small_spz(3, 3);
  v3.flags = 2;
  v3.extensions = extension_record(0x22220001u, {5, 6});
  const std::vector<Valid> files = {{"t.splat", encode_splat(three_splats())},
                                    {"t.spz", encode_spz(small_spz(2, 1))},
                                    {"t.spz", encode_spz(v3)},
                                    {"t.spz", encode_spz(v4)}};
  for (const auto& file : files) {
    const bool splat = std::string(file.name) == "t.splat";
    ASSERT_TRUE(parse_splat_file(file.bytes, file.name).ok());
    for (std::size_t n = 0; n < file.bytes.size(); ++n) {
      if (splat && n > 0 && n % 32 == 0) continue;
      const std::span<const std::uint8_t> prefix(file.bytes.data(), n);
      auto s = splat ? parse_antimatter_splat(prefix, file.name) : parse_spz(prefix, file.name);
      ASSERT_FALSE(s.ok()) << file.name << " prefix " << n << " of " << file.bytes.size();
      EXPECT_EQ(s.message().rfind(std::string(file.name) + ": ", 0), 0u) << s.message();
      EXPECT_TRUE(has(s.message(), "byte offset")) << "prefix " << n << ": " << s.message();
      auto d = parse_splat_file(prefix, file.name);  // through detection: still an error
      ASSERT_FALSE(d.ok()) << file.name << " prefix " << n;
      EXPECT_EQ(d.message().rfind(std::string(file.name) + ": ", 0), 0u) << d.message();
    }
  }
}

// ==== Real files against the PLY they were made from ========================================

struct FieldError {
  double position{0}, log_scale{0}, opacity{0}, sh_dc{0}, sh_rest1{0}, sh_rest23{0}, rotation{0};
  std::size_t clamped_log_scale{0}, clamped_dc{0}, clamped_rest{0};
};

struct Bounds {
  double position, log_scale, opacity, sh_dc, sh_rest1, sh_rest23, rotation;
  double log_scale_lo, log_scale_hi, dc_limit;  // representable source ranges
};

// Compares every field; sources beyond what the format can represent (the writer clamped them)
// are counted, not compared.
FieldError compare(const GaussianCloud& got, const GaussianCloud& ply, const Bounds& b) {
  FieldError e;
  EXPECT_EQ(got.gaussians.size(), ply.gaussians.size());
  const int rest = std::min(got.sh_degree, ply.sh_degree);
  for (std::size_t i = 0; i < std::min(got.gaussians.size(), ply.gaussians.size()); ++i) {
    const Gaussian& a = got.gaussians[i];
    const Gaussian& p = ply.gaussians[i];
    for (int k = 0; k < 3; ++k) {
      e.position = std::max(e.position, double(std::abs(a.position[k] - p.position[k])));
      if (p.log_scale[k] < b.log_scale_lo || p.log_scale[k] > b.log_scale_hi)
        ++e.clamped_log_scale;
      else
        e.log_scale = std::max(e.log_scale, double(std::abs(a.log_scale[k] - p.log_scale[k])));
      if (std::abs(p.sh_dc[k]) > b.dc_limit)
        ++e.clamped_dc;
      else
        e.sh_dc = std::max(e.sh_dc, double(std::abs(a.sh_dc[k] - p.sh_dc[k])));
    }
    e.opacity = std::max(e.opacity, std::abs(test::sigmoid(a.opacity_logit) - test::sigmoid(p.opacity_logit)));
    for (int k = 0; k < sh_rest_count(rest); ++k)
      for (int c = 0; c < 3; ++c) {
        const double v = p.sh_rest[std::size_t(k)][c];
        if (v < -1.0 || v > 1.0) {
          ++e.clamped_rest;
          continue;
        }
        double& m = k < 3 ? e.sh_rest1 : e.sh_rest23;
        m = std::max(m, std::abs(double(a.sh_rest[std::size_t(k)][c]) - v));
      }
    double same = 0, flipped = 0;
    for (int k = 0; k < 4; ++k) {
      same += (a.rotation[k] - p.rotation[k]) * double(a.rotation[k] - p.rotation[k]);
      flipped += (a.rotation[k] + p.rotation[k]) * double(a.rotation[k] + p.rotation[k]);
    }
    e.rotation = std::max(e.rotation, std::sqrt(std::min(same, flipped)));
  }
  EXPECT_LE(e.position, b.position);
  EXPECT_LE(e.log_scale, b.log_scale);
  EXPECT_LE(e.opacity, b.opacity);
  EXPECT_LE(e.sh_dc, b.sh_dc);
  EXPECT_LE(e.sh_rest1, b.sh_rest1);
  EXPECT_LE(e.sh_rest23, b.sh_rest23);
  EXPECT_LE(e.rotation, b.rotation);
  return e;
}

void report(const char* file, const FieldError& e) {
  std::printf(
      "%s max error: position %.3g, log_scale %.3g, opacity %.3g, sh_dc %.3g, sh_rest deg1 %.3g, deg2-3 %.3g, "
      "rotation |dq| %.3g (beyond the format's range, not compared: %zu log-scales, %zu dc, %zu rest)\n",
      file, e.position, e.log_scale, e.opacity, e.sh_dc, e.sh_rest1, e.sh_rest23, e.rotation, e.clamped_log_scale,
      e.clamped_dc, e.clamped_rest);
  const std::string prefix = std::string(file) + ".max_error.";
  ::testing::Test::RecordProperty(prefix + "position", std::to_string(e.position));
  ::testing::Test::RecordProperty(prefix + "log_scale", std::to_string(e.log_scale));
  ::testing::Test::RecordProperty(prefix + "opacity", std::to_string(e.opacity));
  ::testing::Test::RecordProperty(prefix + "sh_dc", std::to_string(e.sh_dc));
  ::testing::Test::RecordProperty(prefix + "sh_rest1", std::to_string(e.sh_rest1));
  ::testing::Test::RecordProperty(prefix + "sh_rest23", std::to_string(e.sh_rest23));
  ::testing::Test::RecordProperty(prefix + "rotation", std::to_string(e.rotation));
}

// SPZ's documented worst cases (splat_spz.cpp), for the reference writer's 12 fractional bits
// and 5/4-bit SH; a hair of float rounding on top.
constexpr double kFloatSlack = 1e-6;
const Bounds kSpzBounds = {
    std::ldexp(1.0, -13) + kFloatSlack,  // position: half of 2^-12
    1.0 / 32 + kFloatSlack,              // log-scale: half of 1/16
    0.5 / 255 + kFloatSlack,             // opacity: half an 8-bit step
    0.5 / (255 * 0.15) + kFloatSlack,    // colour: half a step of 1/(255 * 0.15)
    4.5 / 128 + kFloatSlack,             // degree-1 SH: 5-bit buckets of 8/128, plus rounding
    8.5 / 128 + kFloatSlack,             // degree-2/3 SH: 4-bit buckets of 16/128, plus rounding
    3e-3,                                // rotation: three components within 6.9e-4, the 4th rebuilt
    -10.0,
    5.9375 + 1.0 / 32,
    127.5 / (255 * 0.15)};

// .splat: float positions and scales; 8-bit colour, alpha, rotation. MetalSplatter's writer
// is within one 8-bit step (not half) of its source, so the bounds are one step.
const Bounds kSplatBounds = {
    kFloatSlack,  // positions are float32 in both files
    kFloatSlack,  // linear float32 scale, log on read
    1.0 / 255 + kFloatSlack,
    1.0 / (255 * kShC0) + kFloatSlack,
    0,
    0,
    0.032,  // 8-bit components within 1/128 each, then normalised: 2e/(1-e), e = 2/128
    -1e30,
    1e30,
    1e30};

GaussianCloud read_ply(const std::filesystem::path& path) {
  auto ply = read_gaussian_ply(path);
  EXPECT_TRUE(ply.ok()) << ply.message();
  return ply.ok() ? ply->cloud : GaussianCloud{};
}

TEST(SplatFileData, MetalSplatterSplatMatchesPly) {
  GAUSS_REQUIRE_DATA(ply_path, "splats/metalsplatter_3-points-from-train.ply");
  GAUSS_REQUIRE_DATA(path, "splats/metalsplatter_3-points-from-train.splat");
  auto s = read_splat_file(path);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->report.format, SplatFormat::AntimatterSplat);
  EXPECT_EQ(s->report.count, 3u);
  report("metalsplatter_3-points-from-train.splat", compare(s->cloud, read_ply(ply_path), kSplatBounds));
}

TEST(SplatFileData, MetalSplatterSpzMatchesPly) {
  GAUSS_REQUIRE_DATA(ply_path, "splats/metalsplatter_3-points-from-train.ply");
  GAUSS_REQUIRE_DATA(path, "splats/metalsplatter_3-points-from-train.spz");
  auto s = read_splat_file(path);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->report.format, SplatFormat::Spz);
  EXPECT_EQ(s->report.version, 3u);
  EXPECT_EQ(s->report.sh_degree, 3);
  report("metalsplatter_3-points-from-train.spz", compare(s->cloud, read_ply(ply_path), kSpzBounds));
}

TEST(SplatFileData, FruitDropsSpzV3AndV4MatchPly) {
  GAUSS_REQUIRE_DATA(ply_path, "splats/fruit_drops_sh3.ply");
  GAUSS_REQUIRE_DATA(v3_path, "splats/fruit_drops_sh3.v3.spz");
  GAUSS_REQUIRE_DATA(v4_path, "splats/fruit_drops_sh3.v4.spz");
  const GaussianCloud ply = read_ply(ply_path);
  auto v3 = read_splat_file(v3_path);
  auto v4 = read_splat_file(v4_path);
  ASSERT_TRUE(v3.ok()) << v3.message();
  ASSERT_TRUE(v4.ok()) << v4.message();
  EXPECT_EQ(v3->report.version, 3u);
  EXPECT_EQ(v4->report.version, 4u);
  for (const SplatScene* s : {&*v3, &*v4}) {
    EXPECT_EQ(s->report.count, 4721u);
    EXPECT_EQ(s->report.sh_degree, 3);
    EXPECT_FALSE(s->report.antialiased);
    EXPECT_EQ(s->report.zero_quaternions, 0u);
  }
  report("fruit_drops_sh3.v3.spz", compare(v3->cloud, ply, kSpzBounds));
  report("fruit_drops_sh3.v4.spz", compare(v4->cloud, ply, kSpzBounds));
  // splat-transform wrote the same quantised bytes into both containers.
  ASSERT_EQ(v3->cloud.gaussians.size(), v4->cloud.gaussians.size());
  for (std::size_t i = 0; i < v3->cloud.gaussians.size(); ++i)
    ASSERT_TRUE(same_value(v3->cloud.gaussians[i], v4->cloud.gaussians[i])) << i;
}

}  // namespace
}  // namespace gauss
