// PlayCanvas compressed PLY and SOG readers: hand-made files for every field (written here by
// encoders that follow the PlayCanvas writers), pinned bit layouts, truncations and damaged
// containers, and the real scenes against the PLYs they were made from. The real-scene tests
// print the largest error per field (the figures in the project notes).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <webp/encode.h>
#include <zip.h>

#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/splat_file.h"
#include "opacity.h"
#include "test_data.h"

namespace gauss {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Bytes = std::vector<std::uint8_t>;

const double kSqrt2 = std::sqrt(2.0);
// Float rounding of the decoded values (lerps of floats, stored as float).
constexpr double kEps = 2e-6;

double log_transform(double x) { return std::copysign(std::log1p(std::abs(x)), x); }

// Largest |a - b| over the components, with b's sign flipped when that is closer (q ~ -q).
double quat_distance(const glm::vec4& a, const glm::vec4& b) {
  double plus = 0, minus = 0;
  for (int k = 0; k < 4; ++k) {
    plus = std::max(plus, std::abs(double(a[k]) - b[k]));
    minus = std::max(minus, std::abs(double(a[k]) + b[k]));
  }
  return std::min(plus, minus);
}

bool mentions(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Deterministic cloud with unit quaternions; every field spans a range the formats can hold.
GaussianCloud make_cloud(std::size_t n, int degree, std::uint32_t seed) {
  std::uint32_t s = seed;
  auto rnd = [&]() {
    s = s * 1664525u + 1013904223u;
    return double(s >> 8) / 16777216.0 * 2.0 - 1.0;  // [-1, 1)
  };
  GaussianCloud c;
  c.sh_degree = degree;
  c.gaussians.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Gaussian& g = c.gaussians[i];
    g.position = glm::vec3(rnd() * 3, rnd() * 0.5 + 1, rnd() * 8);
    g.log_scale = glm::vec3(rnd() * 4 - 4, rnd() * 3 - 5, rnd() * 2 - 3);
    glm::vec4 q(rnd(), rnd(), rnd(), rnd());
    const double len = std::sqrt(double(q[0]) * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    g.rotation = len < 1e-3 ? glm::vec4(1, 0, 0, 0) : q / float(len);
    g.opacity_logit = float(rnd() * 5);
    g.sh_dc = glm::vec3(rnd() * 1.5, rnd() * 1.5, rnd() * 1.5);
    for (int k = 0; k < sh_rest_count(degree); ++k)
      g.sh_rest[std::size_t(k)] = glm::vec3(rnd() * 3.9, rnd() * 0.5, rnd() * 0.1);
  }
  return c;
}

// ---------------------------------------------------------------------------------------------
// Compressed PLY: a raw file builder and an encoder that follows splat-transform's writer.

struct RawCompressedPly {
  bool colour_bounds{true};
  bool big_endian{false};
  int sh_props{0};
  std::vector<std::array<float, 18>> chunks;
  std::vector<std::array<std::uint32_t, 4>> words;
  Bytes sh;  // words.size() * sh_props bytes

  Bytes bytes() const {
    static const char* names[18] = {"min_x", "min_y", "min_z", "max_x", "max_y", "max_z",
                                    "min_scale_x", "min_scale_y", "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z",
                                    "min_r", "min_g", "min_b", "max_r", "max_g", "max_b"};
    const int nprops = colour_bounds ? 18 : 12;
    std::string h = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") + " 1.0\n";
    h += "element chunk " + std::to_string(chunks.size()) + "\n";
    for (int k = 0; k < nprops; ++k) h += std::string("property float ") + names[k] + "\n";
    h += "element vertex " + std::to_string(words.size()) + "\n";
    for (const char* p : {"packed_position", "packed_rotation", "packed_scale", "packed_color"})
      h += std::string("property uint ") + p + "\n";
    if (sh_props > 0) {
      h += "element sh " + std::to_string(words.size()) + "\n";
      for (int k = 0; k < sh_props; ++k) h += "property uchar f_rest_" + std::to_string(k) + "\n";
    }
    h += "end_header\n";
    Bytes out(h.begin(), h.end());
    auto put = [&](const void* p, std::size_t n) {
      const auto* b = static_cast<const std::uint8_t*>(p);
      for (std::size_t k = 0; k < n; ++k) out.push_back(b[big_endian ? n - 1 - k : k]);
    };
    for (const auto& c : chunks)
      for (int k = 0; k < nprops; ++k) put(&c[std::size_t(k)], 4);
    for (const auto& w : words)
      for (std::uint32_t v : w) put(&v, 4);
    out.insert(out.end(), sh.begin(), sh.end());
    return out;
  }
};

std::uint32_t pack_unorm(double v, int bits) {
  const double top = double((1u << bits) - 1u);
  return std::uint32_t(std::clamp(std::floor(v * top + 0.5), 0.0, top));
}

double normalize01(double x, double lo, double hi) {
  if (x <= lo) return 0;
  if (x >= hi) return 1;
  return hi - lo < 1e-5 ? 0 : (x - lo) / (hi - lo);
}

RawCompressedPly encode_compressed(const GaussianCloud& c) {
  RawCompressedPly raw;
  raw.sh_props = 3 * sh_rest_count(c.sh_degree);
  const std::size_t n = c.gaussians.size();
  for (std::size_t first = 0; first < n; first += 256) {
    const std::size_t last = std::min(n, first + 256);
    std::array<float, 18> b{};
    auto field = [&](const Gaussian& g, int f) -> double {  // 0..8: position, log-scale, colour
      if (f < 3) return g.position[f];
      if (f < 6) return std::clamp(double(g.log_scale[f - 3]), -20.0, 20.0);
      return g.sh_dc[f - 6] * kShC0 + 0.5;
    };
    for (int f = 0; f < 9; ++f) {
      double lo = 1e300, hi = -1e300;
      for (std::size_t i = first; i < last; ++i) lo = std::min(lo, field(c.gaussians[i], f)), hi = std::max(hi, field(c.gaussians[i], f));
      const std::size_t base = std::size_t(f / 3) * 6 + std::size_t(f % 3);
      b[base] = float(lo);
      b[base + 3] = float(hi);
    }
    raw.chunks.push_back(b);
    for (std::size_t i = first; i < last; ++i) {
      const Gaussian& g = c.gaussians[i];
      std::array<std::uint32_t, 4> w{};
      auto pack3 = [&](int f0) {
        std::uint32_t v[3];
        for (int a = 0; a < 3; ++a) {
          const std::size_t base = std::size_t((f0 + a) / 3) * 6 + std::size_t((f0 + a) % 3);
          v[a] = pack_unorm(normalize01(field(g, f0 + a), b[base], b[base + 3]), a == 1 ? 10 : 11);
        }
        return v[0] << 21 | v[1] << 11 | v[2];
      };
      w[0] = pack3(0);
      w[2] = pack3(3);
      int largest = 0;
      for (int k = 1; k < 4; ++k)
        if (std::abs(g.rotation[k]) > std::abs(g.rotation[largest])) largest = k;
      const double sign = g.rotation[largest] < 0 ? -1 : 1;
      std::uint32_t r = std::uint32_t(largest);
      for (int k = 0; k < 4; ++k)
        if (k != largest) r = r << 10 | pack_unorm(sign * g.rotation[k] * kSqrt2 * 0.5 + 0.5, 10);
      w[1] = r;
      std::uint32_t col = 0;
      for (int a = 0; a < 3; ++a)
        col |= pack_unorm(normalize01(field(g, 6 + a), b[12 + std::size_t(a)], b[15 + std::size_t(a)]), 8) << (24 - 8 * a);
      w[3] = col | pack_unorm(test::sigmoid(g.opacity_logit), 8);
      raw.words.push_back(w);
      const int coefs = sh_rest_count(c.sh_degree);
      for (int ch = 0; ch < 3; ++ch)
        for (int k = 0; k < coefs; ++k)
          raw.sh.push_back(std::uint8_t(std::clamp(std::trunc((g.sh_rest[std::size_t(k)][ch] / 8.0 + 0.5) * 256.0), 0.0, 255.0)));
    }
  }
  return raw;
}

// A two-splat file with SH degree 1 and colour bounds, for the error tests.
RawCompressedPly small_compressed() {
  RawCompressedPly raw = encode_compressed(make_cloud(2, 1, 5));
  return raw;
}

// Per-chunk extents of the source values: the writer's bounds, so the decoding error of each
// field is checked against its own chunk's quantisation step.
struct FieldErrors {
  double position{0}, log_scale{0}, rotation{0}, alpha{0}, sh_dc{0}, sh_rest{0};
  // Largest error relative to the stated bound (<= 1 passes).
  double worst_ratio{0};
  std::string worst;
  void note(double err, double bound, const char* what, std::size_t i) {
    if (bound > 0 && err / bound > worst_ratio) {
      worst_ratio = err / bound;
      worst = std::string(what) + " of Gaussian " + std::to_string(i) + ": error " + std::to_string(err) +
              ", bound " + std::to_string(bound);
    }
  }
  void print(const char* label) const {
    std::printf("[%s] max error: position %.3g, log-scale %.3g, rotation %.3g (per component, up to sign), "
                "opacity %.3g (alpha), sh_dc %.3g, sh_rest %.3g\n",
                label, position, log_scale, rotation, alpha, sh_dc, sh_rest);
  }
};

// Checks a compressed-PLY decode against its source: decoded[i] came from source[match[i]],
// and decoded index i sits in chunk i / 256.
FieldErrors check_compressed(const GaussianCloud& decoded, const GaussianCloud& source, const std::vector<std::size_t>& match,
                             bool colour_bounds) {
  FieldErrors e;
  const std::size_t n = decoded.gaussians.size();
  const int coefs = sh_rest_count(decoded.sh_degree);
  for (std::size_t first = 0; first < n; first += 256) {
    const std::size_t last = std::min(n, first + 256);
    double lo[9], hi[9];
    std::fill(lo, lo + 9, 1e300);
    std::fill(hi, hi + 9, -1e300);
    for (std::size_t i = first; i < last; ++i) {
      const Gaussian& s = source.gaussians[match[i]];
      for (int a = 0; a < 3; ++a) {
        const double v[3] = {s.position[a], std::clamp(double(s.log_scale[a]), -20.0, 20.0), s.sh_dc[a] * kShC0 + 0.5};
        for (int f = 0; f < 3; ++f) lo[f * 3 + a] = std::min(lo[f * 3 + a], v[f]), hi[f * 3 + a] = std::max(hi[f * 3 + a], v[f]);
      }
    }
    for (std::size_t i = first; i < last; ++i) {
      const Gaussian& d = decoded.gaussians[i];
      const Gaussian& s = source.gaussians[match[i]];
      for (int a = 0; a < 3; ++a) {
        const double steps = a == 1 ? 1023.0 : 2047.0;
        const double pext = hi[a] - lo[a], sext = hi[3 + a] - lo[3 + a];
        const double pbound = (pext < 1e-5 ? 1e-5 : pext / (2 * steps)) + kEps * (1 + std::abs(s.position[a]));
        const double sbound = (sext < 1e-5 ? 1e-5 : sext / (2 * steps)) + kEps * (1 + std::abs(s.log_scale[a]));
        const double perr = std::abs(double(d.position[a]) - s.position[a]);
        const double serr = std::abs(double(d.log_scale[a]) - std::clamp(double(s.log_scale[a]), -20.0, 20.0));
        e.position = std::max(e.position, perr);
        e.log_scale = std::max(e.log_scale, serr);
        e.note(perr, pbound, "position", i);
        e.note(serr, sbound, "log-scale", i);
        const double colour = std::clamp(s.sh_dc[a] * kShC0 + 0.5, colour_bounds ? -1e30 : 0.0, colour_bounds ? 1e30 : 1.0);
        const double cext = colour_bounds ? hi[6 + a] - lo[6 + a] : 1.0;
        const double cerr = std::abs(double(d.sh_dc[a]) - (colour - 0.5) / kShC0);
        e.sh_dc = std::max(e.sh_dc, cerr);
        e.note(cerr, (cext < 1e-5 ? 1e-5 : cext / 510.0) / kShC0 + kEps, "sh_dc", i);
      }
      const double rerr = quat_distance(d.rotation, s.rotation);
      e.rotation = std::max(e.rotation, rerr);
      e.note(rerr, 3 * kSqrt2 / 2046 + 1e-4, "rotation", i);
      const double aerr = std::abs(test::sigmoid(d.opacity_logit) - test::sigmoid(s.opacity_logit));
      e.alpha = std::max(e.alpha, aerr);
      e.note(aerr, 0.5 / 255 + kEps, "opacity (alpha)", i);
      for (int k = 0; k < coefs; ++k)
        for (int ch = 0; ch < 3; ++ch) {
          const double v = s.sh_rest[std::size_t(k)][ch];
          const double err = std::abs(double(d.sh_rest[std::size_t(k)][ch]) - std::clamp(v, -4.0, 4.0));
          e.sh_rest = std::max(e.sh_rest, err);
          e.note(err, (std::abs(v) < 4 - 1.0 / 32 ? 1.0 / 64 : 1.0 / 32) + kEps, "sh_rest", i);
        }
    }
  }
  return e;
}

std::vector<std::size_t> identity_match(std::size_t n) {
  std::vector<std::size_t> m(n);
  for (std::size_t i = 0; i < n; ++i) m[i] = i;
  return m;
}

// Whether a decoded opacity came from an alpha byte of 0 (the low clamp).
bool alpha_byte_zero(const Gaussian& g) { return g.opacity_logit < -6.2f; }

// For each decoded Gaussian, its source Gaussian: among those within `radius` of its position
// (the scene here has 156 pairs closer than 3e-4, about two compressed-PLY position steps),
// the one that also agrees best in scale, colour, opacity and rotation; the nearest position
// when none is that close. Colour is left out for an alpha byte of 0 (see the SOG test).
// Brute force (the real scenes here are 4,721 Gaussians). Fails the test unless the match is
// a permutation.
std::vector<std::size_t> match_as_set(const GaussianCloud& decoded, const GaussianCloud& source, double radius) {
  std::vector<std::size_t> match(decoded.gaussians.size());
  std::vector<int> used(source.gaussians.size(), 0);
  for (std::size_t i = 0; i < match.size(); ++i) {
    const Gaussian& a = decoded.gaussians[i];
    double best_cost = 1e300, best_d2 = 1e300;
    std::size_t nearest_j = 0;
    bool close = false;
    for (std::size_t j = 0; j < source.gaussians.size(); ++j) {
      const Gaussian& b = source.gaussians[j];
      const glm::vec3 d = b.position - a.position;
      const double d2 = double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z;
      if (d2 < best_d2) best_d2 = d2, nearest_j = j;
      if (d2 > radius * radius) continue;
      double cost = d2 / (radius * radius) + std::pow(quat_distance(a.rotation, b.rotation) / 0.01, 2) +
                    std::pow((test::sigmoid(a.opacity_logit) - test::sigmoid(b.opacity_logit)) / 0.004, 2);
      for (int k = 0; k < 3; ++k) {
        cost += std::pow((a.log_scale[k] - b.log_scale[k]) / 0.01, 2);
        if (!alpha_byte_zero(a)) cost += std::pow((a.sh_dc[k] - b.sh_dc[k]) / 0.02, 2);
      }
      if (cost < best_cost) best_cost = cost, match[i] = j, close = true;
    }
    if (!close) match[i] = nearest_j;
    ++used[match[i]];
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 1), std::ptrdiff_t(used.size()))
      << "matching by position and attributes is not one-to-one";
  return match;
}

// ---------------------------------------------------------------------------------------------
// Compressed PLY tests.

TEST(CompressedPly, EncodedCloudDecodesWithinEachFieldsQuantisation) {
  for (int degree : {0, 1, 2, 3}) {
    const GaussianCloud src = make_cloud(300, degree, 11 + std::uint32_t(degree));  // 2 chunks, the second partial
    for (bool colour_bounds : {true, false}) {
      for (bool big_endian : {false, true}) {
        RawCompressedPly raw = encode_compressed(src);
        raw.big_endian = big_endian;
        if (!colour_bounds) {
          // Older files: colour stored as is (clamped to [0, 1]), chunks of 12 floats.
          raw.colour_bounds = false;
          for (std::size_t i = 0; i < raw.words.size(); ++i) {
            std::uint32_t col = raw.words[i][3] & 0xFF;
            for (int a = 0; a < 3; ++a)
              col |= pack_unorm(std::clamp(src.gaussians[i].sh_dc[a] * kShC0 + 0.5, 0.0, 1.0), 8) << (24 - 8 * a);
            raw.words[i][3] = col;
          }
        }
        auto scene = parse_compressed_ply(raw.bytes(), "made.ply");
        ASSERT_TRUE(scene.ok()) << scene.message();
        EXPECT_EQ(scene->report.format, SplatFormat::CompressedPly);
        EXPECT_EQ(scene->report.count, 300u);
        EXPECT_EQ(scene->report.sh_degree, degree);
        ASSERT_EQ(scene->cloud.gaussians.size(), 300u);
        for (std::size_t i = 0; i < 300; ++i) {
          EXPECT_EQ(scene->cloud.gaussians[i].id, GaussianId{i});
          EXPECT_EQ(scene->cloud.gaussians[i].object, kNoObject);
        }
        const FieldErrors e = check_compressed(scene->cloud, src, identity_match(300), colour_bounds);
        EXPECT_LE(e.worst_ratio, 1.0) << "degree " << degree << ", colour bounds " << colour_bounds << ": " << e.worst;
      }
    }
  }
}

TEST(CompressedPly, PinnedBitLayout) {
  RawCompressedPly raw;
  raw.sh_props = 9;
  raw.chunks.push_back({-1, 2, -3, 1, 4, 5, -5, -4, -3, -1, 0, 1, 0.1f, 0.2f, 0.3f, 0.9f, 0.8f, 0.7f});
  // x = max (2047), y = min (0), z = 1023/2047 of the way; scale x = min, y = max, z = 1/2047.
  const std::uint32_t pos = 2047u << 21 | 0u << 11 | 1023u;
  const std::uint32_t scale = 0u << 21 | 1023u << 11 | 1u;
  // Largest = y (index 2); stored w = +max (1023), x = -max (0), z = 511.
  const std::uint32_t rot = 2u << 30 | 1023u << 20 | 0u << 10 | 511u;
  // R = 255 (max_r), G = 0 (min_g), B = 51 (1/5 of the way), alpha = 255 (clamped).
  const std::uint32_t col = 255u << 24 | 0u << 16 | 51u << 8 | 255u;
  raw.words.push_back({pos, rot, scale, col});
  raw.sh = {0, 255, 128, 1, 254, 64, 100, 200, 127};
  auto scene = parse_compressed_ply(raw.bytes(), "pinned.ply");
  ASSERT_TRUE(scene.ok()) << scene.message();
  const Gaussian& g = scene->cloud.gaussians.at(0);
  EXPECT_FLOAT_EQ(g.position.x, 1.0f);
  EXPECT_FLOAT_EQ(g.position.y, 2.0f);
  EXPECT_FLOAT_EQ(g.position.z, float(-3.0 + 8.0 * 1023.0 / 2047.0));
  EXPECT_FLOAT_EQ(g.log_scale.x, -5.0f);
  EXPECT_FLOAT_EQ(g.log_scale.y, 0.0f);
  EXPECT_FLOAT_EQ(g.log_scale.z, float(-3.0 + 4.0 / 2047.0));
  const double w = 0.5 * kSqrt2, x = -0.5 * kSqrt2, z = (511.0 / 1023.0 - 0.5) * kSqrt2;
  EXPECT_NEAR(g.rotation[0], w, 1e-6);
  EXPECT_NEAR(g.rotation[1], x, 1e-6);
  EXPECT_NEAR(g.rotation[2], std::sqrt(std::max(0.0, 1 - w * w - x * x - z * z)), 1e-6);
  EXPECT_NEAR(g.rotation[3], z, 1e-6);
  EXPECT_NEAR(g.sh_dc.x, (0.9 - 0.5) / kShC0, 1e-5);
  EXPECT_NEAR(g.sh_dc.y, (0.2 - 0.5) / kShC0, 1e-5);
  EXPECT_NEAR(g.sh_dc.z, (0.3 + 0.4 * 51.0 / 255.0 - 0.5) / kShC0, 1e-5);
  EXPECT_NEAR(g.opacity_logit, std::log(509.0), 1e-5);  // alpha 255 -> logit(1 - 0.5/255)
  // f_rest is channel-major in the file: f_rest_{c*3 + k} is coefficient k+1 of channel c.
  EXPECT_FLOAT_EQ(g.sh_rest[0].r, -4.0f);
  EXPECT_FLOAT_EQ(g.sh_rest[1].r, 4.0f);
  EXPECT_FLOAT_EQ(g.sh_rest[2].r, float((128.5 / 256 - 0.5) * 8));
  EXPECT_FLOAT_EQ(g.sh_rest[0].g, float((1.5 / 256 - 0.5) * 8));
  EXPECT_FLOAT_EQ(g.sh_rest[1].g, float((254.5 / 256 - 0.5) * 8));
  EXPECT_FLOAT_EQ(g.sh_rest[2].b, float((127.5 / 256 - 0.5) * 8));
  // Alpha 0 is clamped the other way.
  raw.words[0][3] = col & ~0xFFu;
  auto low = parse_compressed_ply(raw.bytes(), "pinned.ply");
  ASSERT_TRUE(low.ok()) << low.message();
  EXPECT_NEAR(low->cloud.gaussians[0].opacity_logit, -std::log(509.0), 1e-5);
}

TEST(CompressedPly, DispatcherDetectsIt) {
  auto scene = parse_splat_file(small_compressed().bytes(), "x.ply");
  ASSERT_TRUE(scene.ok()) << scene.message();
  EXPECT_EQ(scene->report.format, SplatFormat::CompressedPly);
  EXPECT_EQ(scene->report.sh_degree, 1);
}

TEST(CompressedPly, EveryTruncatedPrefixIsAnErrorNamingAByteOffset) {
  const Bytes full = small_compressed().bytes();
  ASSERT_TRUE(parse_compressed_ply(full, "cut.ply").ok());
  for (std::size_t len = 0; len < full.size(); ++len) {
    const Bytes cut(full.begin(), full.begin() + std::ptrdiff_t(len));
    auto scene = parse_compressed_ply(cut, "cut.ply");
    ASSERT_FALSE(scene.ok()) << "prefix of " << len << " bytes was accepted";
    EXPECT_EQ(scene.message().rfind("cut.ply: ", 0), 0u) << scene.message();
    EXPECT_TRUE(mentions(scene.message(), "byte offset")) << len << ": " << scene.message();
  }
}

TEST(CompressedPly, MalformedFilesAreRejectedWithClearMessages) {
  struct Case {
    std::string what;
    Bytes bytes;
    std::vector<std::string> expect;
  };
  std::vector<Case> cases;
  const RawCompressedPly good = small_compressed();
  auto edit_header = [&](const std::string& from, const std::string& to, Bytes b) {
    const std::string text(b.begin(), b.end());
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    Bytes out(b.begin(), b.begin() + std::ptrdiff_t(at));
    out.insert(out.end(), to.begin(), to.end());
    out.insert(out.end(), b.begin() + std::ptrdiff_t(at + from.size()), b.end());
    return out;
  };
  {
    Bytes b = good.bytes();
    b.push_back(0);
    cases.push_back({"trailing", b, {"1 bytes of unexpected data", "byte offset " + std::to_string(b.size() - 1)}});
  }
  {
    RawCompressedPly r = good;
    r.chunks.push_back(r.chunks[0]);
    Bytes b = r.bytes();
    cases.push_back({"chunk_count", b, {"element 'chunk'", "has 2 items but 2 vertices need ceil(2 / 256) = 1"}});
  }
  {
    RawCompressedPly r = good;
    r.chunks[0][4] = std::numeric_limits<float>::quiet_NaN();
    const Bytes b = r.bytes();
    const std::string text(b.begin(), b.end());
    const std::size_t data = text.find("end_header\n") + 11;
    cases.push_back({"nan_bound", b, {"chunk 0, property 'max_y'", "byte offset " + std::to_string(data + 16), "NaN"}});
  }
  {
    RawCompressedPly r = good;
    r.chunks[0][15] = 3e38f;  // max_r: f_dc = (3e38 - 0.5) / SH_C0 is no float
    cases.push_back({"colour_bound_overflow", r.bytes(), {"chunk 0, property 'max_r'", "byte offset", "beyond the float range"}});
  }
  cases.push_back({"ascii", edit_header("binary_little_endian", "ascii", good.bytes()), {"must be binary"}});
  cases.push_back({"float_packed", edit_header("property uint packed_scale", "property float packed_scale", good.bytes()),
                   {"'packed_scale'", "is float; expected uint"}});
  cases.push_back({"unknown_vertex_property", edit_header("packed_color", "packed_colour", good.bytes()),
                   {"unexpected property 'packed_colour'"}});
  cases.push_back({"missing_chunk_property",
                   edit_header("property float min_scale_z\n", "", good.bytes()), {"has no property 'min_scale_z'"}});
  cases.push_back({"five_colour_bounds", edit_header("property float max_b\n", "", good.bytes()),
                   {"'max_b'", "all six or none"}});
  cases.push_back({"sh_props_8", edit_header("property uchar f_rest_8\n", "", good.bytes()),
                   {"element 'sh'", "8 properties; expected 9, 24 or 45"}});
  cases.push_back({"sh_gap", edit_header("property uchar f_rest_8\n", "property uchar f_rest_9\n", good.bytes()),
                   {"no property 'f_rest_8'"}});
  cases.push_back({"sh_count", edit_header("element sh 2", "element sh 1", good.bytes()),
                   {"element 'sh'", "1 items but 'vertex' has 2"}});
  cases.push_back({"extra_element", edit_header("end_header", "element face 0\nproperty uchar x\nend_header", good.bytes()),
                   {"unexpected element 'face'"}});
  cases.push_back({"no_chunk", edit_header("element chunk", "element chunks", good.bytes()), {"no 'chunk' element"}});
  cases.push_back({"vertex_count_4e9", edit_header("element vertex 2", "element vertex 4000000000", good.bytes()),
                   {"byte offset"}});
  for (const Case& c : cases) {
    auto scene = parse_compressed_ply(c.bytes, "bad.ply");
    ASSERT_FALSE(scene.ok()) << c.what << " was accepted";
    EXPECT_EQ(scene.message().rfind("bad.ply: ", 0), 0u) << c.what << ": " << scene.message();
    for (const std::string& part : c.expect) EXPECT_TRUE(mentions(scene.message(), part)) << c.what << ": " << scene.message();
  }
}

// ---------------------------------------------------------------------------------------------
// SOG: images, an encoder that follows splat-transform's (truncating) writer, folders and zips.

Bytes webp_lossless(const Bytes& rgba, int w, int h) {
  WebPConfig config;
  EXPECT_TRUE(WebPConfigInit(&config));
  config.lossless = 1;
  config.exact = 1;  // keep RGB under alpha 0: the channels are data
  config.method = 0;
  WebPPicture pic;
  EXPECT_TRUE(WebPPictureInit(&pic));
  pic.use_argb = 1;
  pic.width = w;
  pic.height = h;
  EXPECT_TRUE(WebPPictureImportRGBA(&pic, rgba.data(), w * 4));
  WebPMemoryWriter writer;
  WebPMemoryWriterInit(&writer);
  pic.writer = WebPMemoryWrite;
  pic.custom_ptr = &writer;
  EXPECT_TRUE(WebPEncode(&config, &pic));
  Bytes out(writer.mem, writer.mem + writer.size);
  WebPMemoryWriterClear(&writer);
  WebPPictureFree(&pic);
  return out;
}

Bytes webp_lossy(const Bytes& rgba, int w, int h) {
  std::uint8_t* out = nullptr;
  const std::size_t n = WebPEncodeRGBA(rgba.data(), w, h, w * 4, 90, &out);
  Bytes b(out, out + n);
  WebPFree(out);
  return b;
}

struct SogFiles {
  json meta;
  std::map<std::string, Bytes> files;  // name -> WebP bytes
  int width{0}, height{0};
};

// Evenly spaced codebook over [lo, hi] and the index nearest to v.
std::vector<double> even_codebook(double lo, double hi) {
  std::vector<double> cb(256);
  for (int k = 0; k < 256; ++k) cb[std::size_t(k)] = lo + (hi - lo) * k / 255.0;
  return cb;
}
std::uint8_t nearest(const std::vector<double>& cb, double v) {
  const double lo = cb.front(), hi = cb.back();
  return std::uint8_t(std::clamp(std::floor((v - lo) / (hi - lo) * 255.0 + 0.5), 0.0, 255.0));
}

// Version 2 SOG of `c`. SH entries are a palette with one entry per Gaussian, in the order
// label(i) = (i * 7) % n, so labels and the centroid layout are both exercised.
SogFiles encode_sog(const GaussianCloud& c) {
  SogFiles s;
  const std::size_t n = c.gaussians.size();
  s.width = int(std::ceil(std::sqrt(double(n)) / 4) * 4);
  s.height = int(std::ceil(double(n) / s.width / 4) * 4);
  const std::size_t px = std::size_t(s.width) * std::size_t(s.height);
  Bytes lo(px * 4, 0), hi(px * 4, 0), quats(px * 4, 0), scales(px * 4, 0), sh0(px * 4, 0), labels(px * 4, 0);
  double mn[3] = {1e300, 1e300, 1e300}, mx[3] = {-1e300, -1e300, -1e300};
  double smin = 1e300, smax = -1e300, cmin = 1e300, cmax = -1e300, rmin = 1e300, rmax = -1e300;
  const int coefs = sh_rest_count(c.sh_degree);
  for (const Gaussian& g : c.gaussians)
    for (int a = 0; a < 3; ++a) {
      mn[a] = std::min(mn[a], log_transform(g.position[a])), mx[a] = std::max(mx[a], log_transform(g.position[a]));
      smin = std::min(smin, double(g.log_scale[a])), smax = std::max(smax, double(g.log_scale[a]));
      cmin = std::min(cmin, double(g.sh_dc[a])), cmax = std::max(cmax, double(g.sh_dc[a]));
      for (int k = 0; k < coefs; ++k)
        rmin = std::min(rmin, double(g.sh_rest[std::size_t(k)][a])), rmax = std::max(rmax, double(g.sh_rest[std::size_t(k)][a]));
    }
  const auto scb = even_codebook(smin, smax), ccb = even_codebook(cmin, cmax), rcb = even_codebook(rmin, rmax);
  for (std::size_t i = 0; i < n; ++i) {
    const Gaussian& g = c.gaussians[i];
    for (int a = 0; a < 3; ++a) {
      const auto q = std::uint32_t(65535 * (log_transform(g.position[a]) - mn[a]) / (mx[a] - mn[a]));
      lo[4 * i + std::size_t(a)] = std::uint8_t(q & 0xFF);
      hi[4 * i + std::size_t(a)] = std::uint8_t(q >> 8);
      scales[4 * i + std::size_t(a)] = nearest(scb, g.log_scale[a]);
      sh0[4 * i + std::size_t(a)] = nearest(ccb, g.sh_dc[a]);
    }
    lo[4 * i + 3] = hi[4 * i + 3] = scales[4 * i + 3] = 255;
    sh0[4 * i + 3] = std::uint8_t(std::min(255.0, test::sigmoid(g.opacity_logit) * 255));
    int largest = 0;
    for (int k = 1; k < 4; ++k)
      if (std::abs(g.rotation[k]) > std::abs(g.rotation[largest])) largest = k;
    const double sign = g.rotation[largest] < 0 ? -1 : 1;
    for (int k = 0, out = 0; k < 4; ++k)
      if (k != largest) quats[4 * i + std::size_t(out++)] = std::uint8_t(255 * (sign * g.rotation[k] * kSqrt2 * 0.5 + 0.5));
    quats[4 * i + 3] = std::uint8_t(252 + largest);
    const std::size_t label = (i * 7) % n;
    labels[4 * i] = std::uint8_t(label & 0xFF);
    labels[4 * i + 1] = std::uint8_t(label >> 8);
    labels[4 * i + 3] = 255;
  }
  json meta = {{"version", 2}, {"count", n}, {"antialias", false}};
  meta["means"] = {{"mins", json::array({mn[0], mn[1], mn[2]})}, {"maxs", json::array({mx[0], mx[1], mx[2]})}, {"files", json::array({"means_l.webp", "means_u.webp"})}};
  meta["scales"] = {{"codebook", scb}, {"files", json::array({"scales.webp"})}};
  meta["quats"] = {{"files", json::array({"quats.webp"})}};
  meta["sh0"] = {{"codebook", ccb}, {"files", json::array({"sh0.webp"})}};
  s.files["means_l.webp"] = webp_lossless(lo, s.width, s.height);
  s.files["means_u.webp"] = webp_lossless(hi, s.width, s.height);
  s.files["quats.webp"] = webp_lossless(quats, s.width, s.height);
  s.files["scales.webp"] = webp_lossless(scales, s.width, s.height);
  s.files["sh0.webp"] = webp_lossless(sh0, s.width, s.height);
  if (coefs > 0) {
    const int cw = 64 * coefs, ch = int((n + 63) / 64);
    Bytes cent(std::size_t(cw) * std::size_t(ch) * 4, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t e = (i * 7) % n;
      for (int k = 0; k < coefs; ++k) {
        const std::size_t at = ((e / 64) * std::size_t(cw) + (e % 64) * std::size_t(coefs) + std::size_t(k)) * 4;
        for (int a = 0; a < 3; ++a) cent[at + std::size_t(a)] = nearest(rcb, c.gaussians[i].sh_rest[std::size_t(k)][a]);
        cent[at + 3] = 255;
      }
    }
    meta["shN"] = {{"count", n}, {"bands", c.sh_degree}, {"codebook", rcb}, {"files", json::array({"shN_centroids.webp", "shN_labels.webp"})}};
    s.files["shN_centroids.webp"] = webp_lossless(cent, cw, ch);
    s.files["shN_labels.webp"] = webp_lossless(labels, s.width, s.height);
  }
  s.meta = meta;
  return s;
}

void write_file(const fs::path& p, const Bytes& b) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

Bytes read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

fs::path write_folder(const SogFiles& s, const std::string& name) {
  const fs::path dir = test::fresh_output_dir("sog_" + name);
  const std::string meta = s.meta.dump();
  write_file(dir / "meta.json", Bytes(meta.begin(), meta.end()));
  for (const auto& [file, bytes] : s.files) write_file(dir / file, bytes);
  return dir;
}

// A zip of the files (meta.json first, as splat-transform writes it).
Bytes zip_of(const SogFiles& s, const std::string& name) {
  const fs::path path = test::fresh_output_dir("sog_" + name) / "scene.sog";
  int err = 0;
  zip_t* z = zip_open(path.string().c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  EXPECT_NE(z, nullptr);
  const std::string meta = s.meta.dump();
  auto add = [&](const std::string& file, const void* data, std::size_t size) {
    zip_source_t* src = zip_source_buffer(z, data, size, 0);
    EXPECT_GE(zip_file_add(z, file.c_str(), src, ZIP_FL_OVERWRITE), 0);
  };
  add("meta.json", meta.data(), meta.size());
  for (const auto& [file, bytes] : s.files) add(file, bytes.data(), bytes.size());
  EXPECT_EQ(zip_close(z), 0);
  return read_all(path);
}

// SOG decode vs source (same order): every field against the encoder's bounds.
void check_sog(const GaussianCloud& d, const GaussianCloud& src, const SogFiles& s) {
  ASSERT_EQ(d.gaussians.size(), src.gaussians.size());
  const auto step = [&](const char* field) {
    const auto& cb = s.meta[field]["codebook"];
    return (cb.back().get<double>() - cb.front().get<double>()) / 255.0;
  };
  for (std::size_t i = 0; i < d.gaussians.size(); ++i) {
    const Gaussian& a = d.gaussians[i];
    const Gaussian& b = src.gaussians[i];
    for (int k = 0; k < 3; ++k) {
      const double range = s.meta["means"]["maxs"][std::size_t(k)].get<double>() - s.meta["means"]["mins"][std::size_t(k)].get<double>();
      EXPECT_NEAR(a.position[k], b.position[k], range / 65535 * (1 + std::abs(b.position[k])) + kEps) << i;
      EXPECT_NEAR(a.log_scale[k], b.log_scale[k], step("scales") / 2 + kEps) << i;
      EXPECT_NEAR(a.sh_dc[k], b.sh_dc[k], step("sh0") / 2 + kEps) << i;
      for (int c = 0; c < sh_rest_count(src.sh_degree); ++c)
        EXPECT_NEAR(a.sh_rest[std::size_t(c)][k], b.sh_rest[std::size_t(c)][k], step("shN") / 2 + kEps) << i;
    }
    EXPECT_LE(quat_distance(a.rotation, b.rotation), 3 * kSqrt2 / 255 + 1e-3) << i;
    EXPECT_NEAR(test::sigmoid(a.opacity_logit), test::sigmoid(b.opacity_logit), 1.0 / 255 + kEps) << i;
    EXPECT_EQ(a.id, GaussianId{i});
    EXPECT_EQ(a.object, kNoObject);
  }
}

TEST(Sog, FolderAndZipDecodeEveryFieldWithinTheEncodersQuantisation) {
  for (int degree : {0, 1, 3}) {
    const GaussianCloud src = make_cloud(150, degree, 21 + std::uint32_t(degree));  // 3 palette rows
    const SogFiles s = encode_sog(src);
    const std::string tag = "v2_deg" + std::to_string(degree);
    auto folder = read_sog_folder(write_folder(s, tag));
    ASSERT_TRUE(folder.ok()) << folder.message();
    EXPECT_EQ(folder->report.format, SplatFormat::Sog);
    EXPECT_EQ(folder->report.version, 2u);
    EXPECT_EQ(folder->report.count, 150u);
    EXPECT_EQ(folder->report.sh_degree, degree);
    EXPECT_EQ(folder->cloud.sh_degree, degree);
    check_sog(folder->cloud, src, s);
    // The same files zipped, through the dispatcher; and the folder / meta.json paths.
    auto zipped = parse_splat_file(zip_of(s, tag + "_zip"), "scene.sog");
    ASSERT_TRUE(zipped.ok()) << zipped.message();
    EXPECT_EQ(zipped->report.format, SplatFormat::Sog);
    check_sog(zipped->cloud, src, s);
    auto by_path = read_splat_file(test::output_dir() / ("sog_" + tag) / "meta.json");
    ASSERT_TRUE(by_path.ok()) << by_path.message();
    EXPECT_EQ(by_path->cloud.gaussians.size(), 150u);
  }
}

TEST(Sog, LegacyVersion1RangesDecode) {
  const GaussianCloud src = make_cloud(40, 1, 31);
  SogFiles s = encode_sog(src);
  // Rewrite scales, sh0 and shN as version 1 linear ranges over the same bytes.
  json meta = s.meta;
  meta.erase("version");
  meta.erase("count");
  meta["means"]["shape"] = json::array({40, 3});
  meta["scales"] = {{"mins", json::array({-9, -8, -7})}, {"maxs", json::array({1, 2, 3})}, {"files", json::array({"scales.webp"})}};
  meta["sh0"] = {{"mins", json::array({-2, -1, 0, -6})}, {"maxs", json::array({2, 3, 4, 6})}, {"files", json::array({"sh0.webp"})}};
  meta["shN"] = {{"mins", -0.5}, {"maxs", 1.5}, {"files", json::array({"shN_centroids.webp", "shN_labels.webp"})}};
  s.meta = meta;
  const Bytes scales = [&] {
    Bytes rgba(std::size_t(s.width * s.height) * 4, 255);
    for (std::size_t i = 0; i < 40; ++i)
      for (int a = 0; a < 3; ++a) rgba[4 * i + std::size_t(a)] = std::uint8_t(i * 6 + std::size_t(a));
    return rgba;
  }();
  Bytes sh0 = scales;
  for (std::size_t i = 0; i < 40; ++i) sh0[4 * i + 3] = std::uint8_t(i * 5);
  s.files["scales.webp"] = webp_lossless(scales, s.width, s.height);
  s.files["sh0.webp"] = webp_lossless(sh0, s.width, s.height);
  auto scene = read_sog_folder(write_folder(s, "v1"));
  ASSERT_TRUE(scene.ok()) << scene.message();
  EXPECT_EQ(scene->report.version, 1u);
  EXPECT_EQ(scene->report.sh_degree, 1);  // from the centroid width 192
  auto lerp = [](double lo, double hi, double b) { return lo + (hi - lo) * b / 255.0; };
  for (std::size_t i = 0; i < 40; ++i) {
    const Gaussian& g = scene->cloud.gaussians[i];
    EXPECT_NEAR(g.position.x, src.gaussians[i].position.x, 1e-3);
    EXPECT_FLOAT_EQ(g.log_scale.y, float(lerp(-8, 2, double(i * 6 + 1))));
    EXPECT_FLOAT_EQ(g.sh_dc.z, float(lerp(0, 4, double(i * 6 + 2))));
    EXPECT_FLOAT_EQ(g.opacity_logit, float(lerp(-6, 6, double(i * 5))));  // the logit itself in v1
    EXPECT_LE(quat_distance(g.rotation, src.gaussians[i].rotation), 0.02);
  }
}

TEST(Sog, NullCodebookEntries) {
  const GaussianCloud src = make_cloud(20, 0, 41);
  SogFiles s = encode_sog(src);
  // A null first entry is patched as the PlayCanvas engine does; nothing here uses it.
  json cb = s.meta["scales"]["codebook"];
  const double c1 = cb[1].get<double>(), c255 = cb[255].get<double>();
  bool uses0 = false;
  for (const Gaussian& g : src.gaussians)
    for (int a = 0; a < 3; ++a) uses0 = uses0 || nearest(even_codebook(cb.front().get<double>(), c255), g.log_scale[a]) == 0;
  cb[0] = nullptr;
  s.meta["scales"]["codebook"] = cb;
  auto patched = read_sog_folder(write_folder(s, "null0"));
  ASSERT_TRUE(patched.ok()) << patched.message();
  if (uses0) {
    bool found = false;
    for (const Gaussian& g : patched->cloud.gaussians)
      for (int a = 0; a < 3; ++a) found = found || std::abs(g.log_scale[a] - float(c1 + (c1 - c255) / 255)) < 1e-6;
    EXPECT_TRUE(found);
  }
  // A null entry a pixel uses is an error naming the pixel.
  json sh0cb = s.meta["sh0"]["codebook"];
  const std::uint8_t used = nearest(even_codebook(sh0cb.front().get<double>(), sh0cb.back().get<double>()), src.gaussians[0].sh_dc.x);
  sh0cb[used] = nullptr;
  s.meta["sh0"]["codebook"] = sh0cb;
  auto bad = read_sog_folder(write_folder(s, "null_used"));
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(mentions(bad.message(), "sh0.webp")) << bad.message();
  EXPECT_TRUE(mentions(bad.message(), "Gaussian 0, pixel (0, 0)")) << bad.message();
  EXPECT_TRUE(mentions(bad.message(), "entry " + std::to_string(used) + " of meta.json 'sh0.codebook'")) << bad.message();
}

TEST(Sog, DamagedFilesGiveClearErrors) {
  const GaussianCloud src = make_cloud(30, 1, 51);
  const SogFiles good = encode_sog(src);
  struct Case {
    std::string what;
    SogFiles files;
    std::vector<std::string> expect;
  };
  std::vector<Case> cases;
  auto with = [&](auto edit) {
    SogFiles s = good;
    edit(s);
    return s;
  };
  const Bytes blank(std::size_t(good.width * good.height) * 4, 255);
  cases.push_back({"missing_image", with([](SogFiles& s) { s.files.erase("quats.webp"); }), {"quats.webp"}});
  cases.push_back({"wrong_size", with([&](SogFiles& s) {
                     const Bytes wider(std::size_t((good.width + 4) * good.height) * 4, 255);
                     s.files["scales.webp"] = webp_lossless(wider, good.width + 4, good.height);
                   }),
                   {"scales.webp", "(scales)", "but the other per-Gaussian images are"}});
  cases.push_back({"too_small", with([&](SogFiles& s) {
                     for (const char* f : {"means_l.webp", "means_u.webp"}) s.files[f] = webp_lossless(blank, 4, 4);
                   }),
                   {"means_l.webp", "16 pixels, fewer than meta.json's count of 30"}});
  cases.push_back({"too_large", with([&](SogFiles& s) {
                     const Bytes big(std::size_t(400 * 200) * 4, 255);
                     s.files["means_l.webp"] = webp_lossless(big, 400, 200);
                   }),
                   {"means_l.webp", "not a SOG layout"}});
  cases.push_back({"lossy", with([&](SogFiles& s) { s.files["sh0.webp"] = webp_lossy(blank, good.width, good.height); }),
                   {"sh0.webp", "lossy WebP"}});
  cases.push_back({"not_webp", with([](SogFiles& s) { s.files["quats.webp"] = Bytes{'n', 'o', 'p', 'e'}; }),
                   {"quats.webp", "not a readable WebP"}});
  cases.push_back({"quat_tag", with([&](SogFiles& s) {
                     Bytes q(blank.size(), 128);
                     for (std::size_t i = 0; i < q.size() / 4; ++i) q[4 * i + 3] = i == 7 ? 10 : 252;
                     s.files["quats.webp"] = webp_lossless(q, good.width, good.height);
                   }),
                   {"quats.webp", "Gaussian 7, pixel (7, 0)", "tag (alpha) 10"}});
  cases.push_back({"label_range", with([&](SogFiles& s) {
                     Bytes l(blank.size(), 0);
                     l[4 * 3] = 30;  // palette has 30 entries
                     s.files["shN_labels.webp"] = webp_lossless(l, good.width, good.height);
                   }),
                   {"shN_labels.webp", "Gaussian 3", "label 30", "palette has 30 entries"}});
  cases.push_back({"centroid_width", with([](SogFiles& s) { s.meta["shN"]["bands"] = 2; }),
                   {"shN_centroids.webp", "width 192", "shN.bands = 2 needs 64 x 8 = 512"}});
  cases.push_back({"not_json", with([](SogFiles& s) { s.meta = "x"; }), {"meta.json", "must hold a JSON object"}});
  cases.push_back({"version3", with([](SogFiles& s) { s.meta["version"] = 3; }), {"'version' is 3"}});
  cases.push_back({"negative_count", with([](SogFiles& s) { s.meta["count"] = -1; }), {"'count' is -1"}});
  cases.push_back({"huge_count", with([](SogFiles& s) { s.meta["count"] = 1ull << 40; }), {"'count'", "more than the 16777216"}});
  cases.push_back({"no_means", with([](SogFiles& s) { s.meta.erase("means"); }), {"'means' is missing"}});
  cases.push_back({"mins_string", with([](SogFiles& s) { s.meta["means"]["mins"][1] = "0"; }), {"'means.mins[1]' must be a number"}});
  cases.push_back({"escape", with([](SogFiles& s) { s.meta["quats"]["files"][0] = "../quats.webp"; }), {"'quats.files[0]'", "'..'"}});
  cases.push_back({"absolute", with([](SogFiles& s) { s.meta["quats"]["files"][0] = "/etc/quats.webp"; }), {"plain relative name"}});
  cases.push_back({"no_codebook", with([](SogFiles& s) { s.meta["scales"].erase("codebook"); }), {"'scales.codebook' is missing"}});
  cases.push_back({"exp_overflow", with([](SogFiles& s) { s.meta["means"]["maxs"][0] = 100.0; }), {"would overflow a float"}});
  for (const Case& c : cases) {
    auto folder = read_sog_folder(write_folder(c.files, "bad_" + c.what));
    ASSERT_FALSE(folder.ok()) << c.what << " was accepted (folder)";
    auto zipped = parse_sog_zip(zip_of(c.files, "bad_" + c.what + "_zip"), "bad.sog");
    ASSERT_FALSE(zipped.ok()) << c.what << " was accepted (zip)";
    EXPECT_EQ(zipped.message().rfind("bad.sog: ", 0), 0u) << c.what << ": " << zipped.message();
    for (const std::string& part : c.expect) {
      EXPECT_TRUE(mentions(folder.message(), part)) << c.what << " (folder): " << folder.message();
      EXPECT_TRUE(mentions(zipped.message(), part)) << c.what << " (zip): " << zipped.message();
    }
  }
}

TEST(Sog, ZipContainerErrors) {
  const SogFiles good = encode_sog(make_cloud(10, 0, 61));
  const Bytes zip = zip_of(good, "container");
  ASSERT_TRUE(parse_sog_zip(zip, "z.sog").ok());
  // Every truncation is an error naming the input (most cut the central directory; none crash).
  for (std::size_t len = 0; len < zip.size(); ++len) {
    auto scene = parse_sog_zip(Bytes(zip.begin(), zip.begin() + std::ptrdiff_t(len)), "z.sog");
    ASSERT_FALSE(scene.ok()) << "a zip cut to " << len << " bytes was accepted";
    EXPECT_EQ(scene.message().rfind("z.sog: ", 0), 0u) << scene.message();
  }
  auto cut = parse_sog_zip(Bytes(zip.begin(), zip.end() - 10), "z.sog");
  EXPECT_TRUE(mentions(cut.message(), "not a readable zip archive")) << cut.message();
  // Damaged compressed data: flip a byte inside the first entry's (meta.json's) data.
  Bytes flipped = zip;
  flipped[60] ^= 0x55;
  auto damaged = parse_sog_zip(flipped, "z.sog");
  ASSERT_FALSE(damaged.ok());
  EXPECT_TRUE(mentions(damaged.message(), "z.sog: ")) << damaged.message();
  // A zip without meta.json lists what it has.
  SogFiles no_meta = good;
  const fs::path path = test::fresh_output_dir("sog_no_meta") / "x.zip";
  int err = 0;
  zip_t* z = zip_open(path.string().c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  ASSERT_NE(z, nullptr);
  const Bytes& q = good.files.at("quats.webp");
  ASSERT_GE(zip_file_add(z, "quats.webp", zip_source_buffer(z, q.data(), q.size(), 0), 0), 0);
  ASSERT_EQ(zip_close(z), 0);
  auto none = parse_splat_file(read_all(path), "x.zip");
  ASSERT_FALSE(none.ok());
  EXPECT_TRUE(mentions(none.message(), "x.zip: a zip without meta.json")) << none.message();
  EXPECT_TRUE(mentions(none.message(), "quats.webp")) << none.message();
}

// ---------------------------------------------------------------------------------------------
// Real scenes (../shared/data/splats, see its README).

TEST(RealScenes, GuitarCompressedMatchesTheConvertedPly) {
  GAUSS_REQUIRE_DATA(compressed_path, "splats/guitar.compressed.ply");
  GAUSS_REQUIRE_DATA(ply_path, "splats/guitar.ply");
  auto scene = read_splat_file(compressed_path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  auto ply = read_gaussian_ply(ply_path);
  ASSERT_TRUE(ply.ok()) << ply.message();
  EXPECT_EQ(scene->report.format, SplatFormat::CompressedPly);
  ASSERT_EQ(scene->cloud.gaussians.size(), 90854u);
  ASSERT_EQ(ply->cloud.gaussians.size(), 90854u);
  // Same order: guitar.ply was decoded from this file. So the decode must agree with it to
  // float rounding, and lie within the quantisation of its own values.
  double max_diff[6] = {};
  std::size_t clamped = 0;
  for (std::size_t i = 0; i < 90854; ++i) {
    const Gaussian& a = scene->cloud.gaussians[i];
    const Gaussian& b = ply->cloud.gaussians[i];
    for (int k = 0; k < 3; ++k) {
      max_diff[0] = std::max(max_diff[0], double(std::abs(a.position[k] - b.position[k])));
      max_diff[1] = std::max(max_diff[1], double(std::abs(a.log_scale[k] - b.log_scale[k])));
      max_diff[4] = std::max(max_diff[4], double(std::abs(a.sh_dc[k] - b.sh_dc[k])));
    }
    max_diff[2] = std::max(max_diff[2], quat_distance(a.rotation, b.rotation));
    max_diff[3] = std::max(max_diff[3], std::abs(test::sigmoid(a.opacity_logit) - test::sigmoid(b.opacity_logit)));
    max_diff[5] = std::max(max_diff[5], double(std::abs(a.opacity_logit - b.opacity_logit)));
    clamped += std::abs(a.opacity_logit - float(std::log(509.0))) < 1e-5f ? 1 : 0;
  }
  std::printf("[guitar.compressed.ply vs guitar.ply, same order] max difference: position %.3g, log-scale %.3g, "
              "rotation %.3g, opacity %.3g (alpha) / %.3g (logit), sh_dc %.3g; %zu opacities at the clamp logit(1 - 0.5/255)\n",
              max_diff[0], max_diff[1], max_diff[2], max_diff[3], max_diff[5], max_diff[4], clamped);
  EXPECT_LT(max_diff[0], 1e-5);
  EXPECT_LT(max_diff[1], 1e-5);
  EXPECT_LT(max_diff[2], 1e-5);
  EXPECT_LT(max_diff[3], 1e-6);
  EXPECT_LT(max_diff[4], 1e-5);
  EXPECT_EQ(clamped, 667u);
  const FieldErrors e = check_compressed(scene->cloud, ply->cloud, identity_match(90854), true);
  EXPECT_LE(e.worst_ratio, 1.0) << e.worst;
}

TEST(RealScenes, FruitDropsCompressedPlyMatchesTheSourceAsASet) {
  GAUSS_REQUIRE_DATA(compressed_path, "splats/fruit_drops_sh3.compressed.ply");
  GAUSS_REQUIRE_DATA(ply_path, "splats/fruit_drops_sh3.ply");
  auto scene = read_splat_file(compressed_path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  auto ply = read_gaussian_ply(ply_path);
  ASSERT_TRUE(ply.ok()) << ply.message();
  EXPECT_EQ(scene->report.sh_degree, 3);
  ASSERT_EQ(scene->cloud.gaussians.size(), ply->cloud.gaussians.size());
  const auto match = match_as_set(scene->cloud, ply->cloud, 1e-3);
  const FieldErrors e = check_compressed(scene->cloud, ply->cloud, match, true);
  e.print("fruit_drops_sh3.compressed.ply vs fruit_drops_sh3.ply, matched by position");
  EXPECT_LE(e.worst_ratio, 1.0) << e.worst;
}

TEST(RealScenes, FruitDropsSogMatchesTheSourceAsASet) {
  GAUSS_REQUIRE_DATA(sog_path, "splats/fruit_drops_sh3.sog");
  GAUSS_REQUIRE_DATA(ply_path, "splats/fruit_drops_sh3.ply");
  auto scene = read_splat_file(sog_path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  auto ply = read_gaussian_ply(ply_path);
  ASSERT_TRUE(ply.ok()) << ply.message();
  EXPECT_EQ(scene->report.format, SplatFormat::Sog);
  EXPECT_EQ(scene->report.version, 2u);
  EXPECT_EQ(scene->report.sh_degree, 3);
  const GaussianCloud& d = scene->cloud;
  const GaussianCloud& s = ply->cloud;
  ASSERT_EQ(d.gaussians.size(), s.gaussians.size());
  const auto match = match_as_set(d, s, 1e-4);
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const Gaussian& g : s.gaussians)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], log_transform(g.position[a])), hi[a] = std::max(hi[a], log_transform(g.position[a]));
  FieldErrors e;
  double sh_rest_sum = 0, lost_dc = 0;
  std::size_t sh_rest_n = 0, alpha_zero = 0, lost_far = 0;
  for (const Gaussian& g : d.gaussians) alpha_zero += alpha_byte_zero(g) ? 1 : 0;
  for (std::size_t i = 0; i < d.gaussians.size(); ++i) {
    const Gaussian& a = d.gaussians[i];
    const Gaussian& b = s.gaussians[match[i]];
    for (int k = 0; k < 3; ++k) {
      const double perr = std::abs(double(a.position[k]) - b.position[k]);
      e.position = std::max(e.position, perr);
      e.note(perr, (hi[k] - lo[k]) / 65535 * (1 + std::abs(b.position[k])) + kEps, "position", i);
      e.log_scale = std::max(e.log_scale, double(std::abs(a.log_scale[k] - b.log_scale[k])));
      const double dc_err = std::abs(double(a.sh_dc[k]) - b.sh_dc[k]);
      if (alpha_byte_zero(a))
        lost_dc = std::max(lost_dc, dc_err);
      else
        e.sh_dc = std::max(e.sh_dc, dc_err);
      for (int c = 0; c < sh_rest_count(3); ++c) {
        const double err = std::abs(double(a.sh_rest[std::size_t(c)][k]) - b.sh_rest[std::size_t(c)][k]);
        e.sh_rest = std::max(e.sh_rest, err);
        sh_rest_sum += err * err;
        ++sh_rest_n;
      }
    }
    if (alpha_byte_zero(a) && glm::distance(a.sh_dc, b.sh_dc) > 0.1f) ++lost_far;
    const double rerr = quat_distance(a.rotation, b.rotation);
    e.rotation = std::max(e.rotation, rerr);
    e.note(rerr, 3 * kSqrt2 / 255 + 1e-3, "rotation", i);
    const double aerr = std::abs(test::sigmoid(a.opacity_logit) - test::sigmoid(b.opacity_logit));
    e.alpha = std::max(e.alpha, aerr);
    e.note(aerr, 1.0 / 255 + kEps, "opacity (alpha)", i);
  }
  e.print("fruit_drops_sh3.sog vs fruit_drops_sh3.ply, matched by position");
  std::printf("[fruit_drops_sh3.sog] sh_rest RMS error %.3g over %zu coefficients (k-means palette: lossy by design)\n",
              std::sqrt(sh_rest_sum / double(sh_rest_n)), sh_rest_n);
  // splat-transform 2.7.1 encodes lossless WebP without "exact": where the opacity byte is 0,
  // the encoder was free to replace the colour indices under it (they read back as 0). Those
  // Gaussians are invisible (alpha < 1/255); the sh_dc figure above leaves them out.
  std::printf("[fruit_drops_sh3.sog] %zu Gaussians have alpha byte 0, %zu of them with sh_dc off by more than 0.1 (up "
              "to %.3g): colour indices the writer's WebP encoder did not keep\n", alpha_zero, lost_far, lost_dc);
  EXPECT_LE(lost_far, alpha_zero);
  EXPECT_LE(e.worst_ratio, 1.0) << e.worst;
  // Codebook and palette fields have no bound in the format; these are the measured values
  // with headroom, so a decoding mistake (wrong channel, wrong codebook) still fails.
  EXPECT_LT(e.log_scale, 0.1);
  EXPECT_LT(e.sh_dc, 0.05);
  EXPECT_LT(e.sh_rest, 1.0);
}

// Writes the fuzz seed corpus (run on purpose: --gtest_also_run_disabled_tests
// --gtest_filter='*WriteFuzzSeeds'); each file stays under 4 KiB.
TEST(FuzzSeeds, DISABLED_WriteFuzzSeeds) {
  const fs::path dir = fs::path(GAUSS_SOURCE_DIR) / "tests/fuzz/corpus/compressed_ply";
  fs::create_directories(dir);
  write_file(dir / "two_splats_sh1.ply", small_compressed().bytes());
  RawCompressedPly plain = encode_compressed(make_cloud(3, 0, 71));
  plain.colour_bounds = false;
  write_file(dir / "three_splats_no_colour_bounds.ply", plain.bytes());
  RawCompressedPly be = encode_compressed(make_cloud(1, 3, 72));
  be.big_endian = true;
  write_file(dir / "one_splat_sh3_big_endian.ply", be.bytes());
  // Codebooks of short decimals keep the zip small.
  SogFiles sog = encode_sog(make_cloud(4, 1, 73));
  for (const char* f : {"scales", "sh0", "shN"}) {
    json cb = json::array();
    for (int k = 0; k < 256; ++k) cb.push_back((k - 128) / 16.0);
    sog.meta[f]["codebook"] = cb;
  }
  Bytes z = zip_of(sog, "seed");
  EXPECT_LT(z.size(), 4096u);
  write_file(dir / "four_splats_sh1.sog", z);
}

}  // namespace
}  // namespace gauss
