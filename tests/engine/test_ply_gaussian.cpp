// 3DGS PLY reader/writer: layouts, types, normalisation, round trips and the real scenes.
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <utility>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/ply_gaussian.h"
#include "test_data.h"
#include "text_file.h"

namespace gauss {
namespace {

// Wall and process CPU time: the build machine is shared, so wall time alone says little.
struct Stopwatch {
  std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
  std::clock_t cpu = std::clock();
  std::pair<double, double> elapsed_ms() const {
    return {std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall).count(),
            1000.0 * double(std::clock() - cpu) / CLOCKS_PER_SEC};
  }
};

std::uint32_t bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

// Deterministic pseudo-random cloud with unit quaternions (as a load would leave them).
GaussianCloud make_cloud(std::size_t n, int degree, std::uint32_t seed = 1) {
  std::uint32_t s = seed;
  auto rnd = [&]() {
    s = s * 1664525u + 1013904223u;
    return static_cast<float>(s >> 8) / 16777216.0f * 2.0f - 1.0f;  // [-1, 1)
  };
  GaussianCloud c;
  c.sh_degree = degree;
  c.gaussians.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Gaussian& g = c.gaussians[i];
    g.position = glm::vec3(rnd() * 10, rnd() * 10, rnd() * 10);
    g.log_scale = glm::vec3(rnd() * 5, rnd() * 5, rnd() * 5);
    g.rotation = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
    if (i % 2) g.rotation = glm::vec4(0.5f, -0.5f, 0.5f, 0.5f);  // exactly unit
    g.opacity_logit = rnd() * 6;
    g.sh_dc = glm::vec3(rnd(), rnd(), rnd());
    for (int k = 0; k < sh_rest_count(degree); ++k)
      g.sh_rest[static_cast<std::size_t>(k)] = glm::vec3(rnd(), rnd(), rnd()) * 0.1f;
    g.id = GaussianId{1000 + i * 7};
    g.object = ObjectId{static_cast<std::int32_t>(i % 5) - 1};
    g.support = static_cast<std::uint32_t>(i * 3);
  }
  return c;
}

// Every float bit pattern up to the cloud's degree, plus ids/labels/support when asked.
void expect_bit_equal(const GaussianCloud& a, const GaussianCloud& b, bool ids, bool objects, bool support) {
  ASSERT_EQ(a.sh_degree, b.sh_degree);
  ASSERT_EQ(a.gaussians.size(), b.gaussians.size());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < a.gaussians.size() && mismatches < 5; ++i) {
    const Gaussian& x = a.gaussians[i];
    const Gaussian& y = b.gaussians[i];
    std::vector<float> fx, fy;
    for (int k = 0; k < 3; ++k) {
      fx.insert(fx.end(), {x.position[k], x.log_scale[k], x.sh_dc[k]});
      fy.insert(fy.end(), {y.position[k], y.log_scale[k], y.sh_dc[k]});
    }
    for (int k = 0; k < 4; ++k) {
      fx.push_back(x.rotation[k]);
      fy.push_back(y.rotation[k]);
    }
    fx.push_back(x.opacity_logit);
    fy.push_back(y.opacity_logit);
    for (int k = 0; k < sh_rest_count(a.sh_degree); ++k)
      for (int c = 0; c < 3; ++c) {
        fx.push_back(x.sh_rest[static_cast<std::size_t>(k)][c]);
        fy.push_back(y.sh_rest[static_cast<std::size_t>(k)][c]);
      }
    for (std::size_t k = 0; k < fx.size(); ++k)
      if (bits(fx[k]) != bits(fy[k])) {
        ADD_FAILURE() << "Gaussian " << i << " float " << k << ": " << fx[k] << " vs " << fy[k];
        ++mismatches;
        break;
      }
    if (ids) {
      EXPECT_EQ(to_underlying(x.id), to_underlying(y.id)) << "Gaussian " << i;
    }
    if (objects) {
      EXPECT_EQ(to_underlying(x.object), to_underlying(y.object)) << "Gaussian " << i;
    }
    if (support) {
      EXPECT_EQ(x.support, y.support) << "Gaussian " << i;
    }
  }
}

PlyGaussianScene round_trip(const GaussianCloud& c, const PlyGaussianWriteOptions& o) {
  auto bytes = encode_gaussian_ply(c, o);
  EXPECT_TRUE(bytes.ok()) << (bytes.ok() ? "" : bytes.message());
  if (!bytes) return {};
  auto back = parse_gaussian_ply(*bytes, "roundtrip.ply");
  EXPECT_TRUE(back.ok()) << (back.ok() ? "" : back.message());
  if (!back) return {};
  return std::move(back).value();
}

TEST(PlyGaussian, RoundTripAllFormatsAndDegreesBitExact) {
  for (PlyFormat f : {PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian, PlyFormat::Ascii}) {
    for (int d = 0; d <= kMaxShDegree; ++d) {
      SCOPED_TRACE("format " + std::to_string(int(f)) + " degree " + std::to_string(d));
      const GaussianCloud c = make_cloud(37, d, 11u + unsigned(d));
      PlyGaussianWriteOptions o;
      o.format = f;
      o.write_object_id = o.write_gaussian_id = o.write_support = true;
      const PlyGaussianScene s = round_trip(c, o);
      expect_bit_equal(c, s.cloud, true, true, true);
      EXPECT_EQ(s.report.format, f);
      EXPECT_EQ(s.report.sh_degree, d);
      EXPECT_TRUE(s.report.has_normals);
      EXPECT_TRUE(s.report.has_object_id && s.report.has_gaussian_id && s.report.has_support);
      EXPECT_EQ(s.report.renormalized_quaternions, 0u);
      EXPECT_EQ(s.report.zero_quaternions, 0u);
    }
  }
}

TEST(PlyGaussian, AsciiRoundTripsFloatsThatNeedAllDigits) {
  GaussianCloud c = make_cloud(4, 0);
  // Values whose shortest decimal form needs max_digits10 (9) digits, plus extremes.
  c.gaussians[0].position = glm::vec3(0.1f + 1e-8f, 16777217.0f, 3.4028235e38f);
  c.gaussians[1].position = glm::vec3(1.17549435e-38f, 1.4e-45f, -0.0f);
  c.gaussians[2].opacity_logit = std::nextafter(1.0f, 2.0f);
  PlyGaussianWriteOptions o;
  o.format = PlyFormat::Ascii;
  expect_bit_equal(c, round_trip(c, o).cloud, false, false, false);
}

TEST(PlyGaussian, WithoutOptionalColumnsIdsAreVertexIndices) {
  const GaussianCloud c = make_cloud(5, 1);
  PlyGaussianWriteOptions o;
  o.write_normals = false;
  const PlyGaussianScene s = round_trip(c, o);
  EXPECT_FALSE(s.report.has_normals);
  EXPECT_FALSE(s.report.has_gaussian_id);
  EXPECT_FALSE(s.report.has_object_id);
  EXPECT_FALSE(s.report.has_support);
  for (std::size_t i = 0; i < s.cloud.gaussians.size(); ++i) {
    EXPECT_EQ(to_underlying(s.cloud.gaussians[i].id), i);
    EXPECT_EQ(s.cloud.gaussians[i].object, kNoObject);
    EXPECT_EQ(s.cloud.gaussians[i].support, 0u);
  }
}

TEST(PlyGaussian, LargeIdsUseUint64AndRoundTrip) {
  GaussianCloud c = make_cloud(3, 0);
  c.gaussians[1].id = GaussianId{0x123456789abcdefull};
  PlyGaussianWriteOptions o;
  o.write_gaussian_id = true;
  auto bytes = encode_gaussian_ply(c, o);
  ASSERT_TRUE(bytes.ok());
  EXPECT_NE(std::string(bytes->begin(), bytes->end()).find("property uint64 gaussian_id"), std::string::npos);
  expect_bit_equal(c, round_trip(c, o).cloud, true, false, false);
}

TEST(PlyGaussian, RestIsChannelMajorInTheFile) {
  // Degree 1: f_rest_0..2 are red coefficients 1..3, f_rest_3..5 green, f_rest_6..8 blue.
  std::string ply = "ply\nformat ascii 1.0\nelement vertex 1\n";
  for (const char* n : {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"}) ply += std::string("property float ") + n + "\n";
  for (int k = 0; k < 9; ++k) ply += "property float f_rest_" + std::to_string(k) + "\n";
  for (const char* n : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    ply += std::string("property float ") + n + "\n";
  ply += "end_header\n1 2 3 0.1 0.2 0.3 0 1 2 3 4 5 6 7 8 0.5 -1 -2 -3 1 0 0 0\n";
  auto s = parse_gaussian_ply(test::bytes_of(ply), "rest.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(s->cloud.sh_degree, 1);
  const Gaussian& g = s->cloud.gaussians[0];
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(g.sh_rest[static_cast<std::size_t>(k)][c], float(c * 3 + k));
  EXPECT_EQ(g.position, glm::vec3(1, 2, 3));
  EXPECT_EQ(g.log_scale, glm::vec3(-1, -2, -3));
  EXPECT_EQ(g.opacity_logit, 0.5f);
  // Written back, the file layout is the same channel-major order.
  auto out = encode_gaussian_ply(s->cloud, {PlyFormat::Ascii, false});
  ASSERT_TRUE(out.ok());
  EXPECT_NE(std::string(out->begin(), out->end()).find("\n1 2 3 0.1 0.2 0.3 0 1 2 3 4 5 6 7 8 0.5 -1 -2 -3 1 0 0 0\n"),
            std::string::npos);
}

// Header for a minimal binary LE file in the INRIA order with extra columns appended.
std::string minimal_header(const std::string& format, std::size_t n, const std::string& extra_props = "",
                           const std::string& prefix_elements = "") {
  std::string h = "ply\nformat " + format + " 1.0\ncomment test\n" + prefix_elements + "element vertex " +
                  std::to_string(n) + "\n";
  for (const char* p : {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
                        "rot_0", "rot_1", "rot_2", "rot_3"})
    h += std::string("property float ") + p + "\n";
  return h + extra_props + "end_header\n";
}

TEST(PlyGaussian, QuaternionsNormalisedZeroBecomesIdentityUnitKeptExactly) {
  std::string ply = minimal_header("ascii", 3) +
                    "0 0 0 0 0 0 0 0 0 0 2 0 0 0\n"          // length 2 -> (1,0,0,0), renormalised
                    "0 0 0 0 0 0 0 0 0 0 0 0 0 0\n"          // zero -> identity, counted
                    "0 0 0 0 0 0 0 0 0 0 0.5 0.5 0.5 0.5\n"; // already unit: kept
  auto s = parse_gaussian_ply(test::bytes_of(ply), "q.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->report.renormalized_quaternions, 1u);
  EXPECT_EQ(s->report.zero_quaternions, 1u);
  EXPECT_EQ(s->cloud.gaussians[0].rotation, glm::vec4(1, 0, 0, 0));
  EXPECT_EQ(s->cloud.gaussians[1].rotation, glm::vec4(1, 0, 0, 0));
  EXPECT_EQ(s->cloud.gaussians[2].rotation, glm::vec4(0.5f));
}

TEST(PlyGaussian, ReadingIsIdempotentForNormalisedQuaternions) {
  // Random non-unit quaternions: the first load normalises, the second must not change a bit.
  GaussianCloud c = make_cloud(200, 0, 5);
  std::uint32_t s = 9;
  for (auto& g : c.gaussians) {
    for (int k = 0; k < 4; ++k) {
      s = s * 1664525u + 1013904223u;
      g.rotation[k] = static_cast<float>(s >> 8) / 16777216.0f * 4.0f - 2.0f;
    }
  }
  const PlyGaussianScene first = round_trip(c, {});
  EXPECT_EQ(first.report.renormalized_quaternions, 200u);
  const PlyGaussianScene second = round_trip(first.cloud, {});
  EXPECT_EQ(second.report.renormalized_quaternions, 0u);
  expect_bit_equal(first.cloud, second.cloud, false, false, false);
  for (const auto& g : first.cloud.gaussians) {
    const double n = std::sqrt(double(g.rotation[0]) * g.rotation[0] + double(g.rotation[1]) * g.rotation[1] +
                               double(g.rotation[2]) * g.rotation[2] + double(g.rotation[3]) * g.rotation[3]);
    EXPECT_NEAR(n, 1.0, 1e-6);
  }
}

TEST(PlyGaussian, AcceptsOtherNumericTypesAndSkipsUnknownPropertiesAndElements) {
  // Binary LE: a leading element with a list (must be skipped byte-exactly), a vertex element
  // with doubles, ints, an ignored uchar, an ignored list, and integral-float object ids.
  std::string h = "ply\nformat binary_little_endian 1.0\n"
                  "element extra 2\nproperty list uchar int stuff\nproperty short tag\n"
                  "element vertex 2\nproperty double x\nproperty int y\nproperty short z\n"
                  "property uchar red\nproperty list ushort float junk\n"
                  "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty double opacity\n"
                  "property float scale_0\nproperty float scale_1\nproperty float scale_2\n"
                  "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\n"
                  "property float object_id\nproperty ushort support\nproperty double gaussian_id\n"
                  "element trailer 1\nproperty uint64 big\nend_header\n";
  std::vector<std::uint8_t> b = test::bytes_of(h);
  // extra: item 0 has 2 ints, item 1 has 0.
  b.push_back(2);
  test::append_bytes<std::int32_t>(b, 7);
  test::append_bytes<std::int32_t>(b, 8);
  test::append_bytes<std::int16_t>(b, -1);
  b.push_back(0);
  test::append_bytes<std::int16_t>(b, -2);
  for (int i = 0; i < 2; ++i) {
    test::append_bytes<double>(b, 1.5 + i);
    test::append_bytes<std::int32_t>(b, -3);
    test::append_bytes<std::int16_t>(b, 300);
    b.push_back(200);
    test::append_bytes<std::uint16_t>(b, std::uint16_t(i + 1));  // list of i+1 floats
    for (int k = 0; k <= i; ++k) test::append_bytes<float>(b, 9.0f);
    for (float f : {0.1f, 0.2f, 0.3f}) test::append_bytes<float>(b, f);
    test::append_bytes<double>(b, -2.0);
    for (float f : {-1.0f, -2.0f, -3.0f, 1.0f, 0.0f, 0.0f, 0.0f}) test::append_bytes<float>(b, f);
    test::append_bytes<float>(b, i == 0 ? -1.0f : 4.0f);
    test::append_bytes<std::uint16_t>(b, 65535);
    test::append_bytes<double>(b, 1e15 + i);
  }
  test::append_bytes<std::uint64_t>(b, 42);
  auto s = parse_gaussian_ply(b, "types.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(s->cloud.gaussians.size(), 2u);
  const Gaussian& g = s->cloud.gaussians[1];
  EXPECT_EQ(g.position, glm::vec3(2.5f, -3.0f, 300.0f));
  EXPECT_EQ(g.opacity_logit, -2.0f);
  EXPECT_EQ(to_underlying(s->cloud.gaussians[0].object), -1);
  EXPECT_EQ(to_underlying(g.object), 4);
  EXPECT_EQ(g.support, 65535u);
  EXPECT_EQ(to_underlying(g.id), 1000000000000001ull);
  EXPECT_EQ(s->report.ignored_properties, (std::vector<std::string>{"red", "junk"}));
  EXPECT_EQ(s->report.ignored_elements, (std::vector<std::string>{"extra", "trailer"}));
  EXPECT_TRUE(s->report.has_object_id && s->report.has_support && s->report.has_gaussian_id);
}

TEST(PlyGaussian, BigEndianBytesAreDecodedInFileOrder) {
  // Written by hand (not by our writer) so a symmetric byte-order bug cannot hide.
  std::vector<std::uint8_t> b;
  const std::string h = minimal_header("binary_big_endian", 1, "property int object_id\n");
  b.assign(h.begin(), h.end());
  auto put_be32 = [&](std::uint32_t v) {
    for (int k = 3; k >= 0; --k) b.push_back(std::uint8_t(v >> (8 * k)));
  };
  put_be32(0x3FC00000u);  // x = 1.5
  for (int k = 1; k < 10; ++k) put_be32(0);
  put_be32(0x3F800000u);  // rot_0 = 1
  for (int k = 11; k < 14; ++k) put_be32(0);
  put_be32(0x00000102u);  // object_id = 258
  auto s = parse_gaussian_ply(b, "be.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->cloud.gaussians[0].position.x, 1.5f);
  EXPECT_EQ(to_underlying(s->cloud.gaussians[0].object), 258);
  EXPECT_EQ(s->report.format, PlyFormat::BinaryBigEndian);
}

TEST(PlyGaussian, CrlfHeaderAndAsciiBlankLinesAccepted) {
  std::string ply = minimal_header("ascii", 1);
  std::string crlf;
  for (char c : ply) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  crlf += "\r\n1 2 3 0 0 0 0 0 0 0 1 0 0 0\r\n\r\n";
  auto s = parse_gaussian_ply(test::bytes_of(crlf), "crlf.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->cloud.gaussians[0].position, glm::vec3(1, 2, 3));
}

TEST(PlyGaussian, WriterRejectsWhatNoReaderWouldAccept) {
  GaussianCloud c = make_cloud(3, 2);
  c.gaussians[2].opacity_logit = std::nanf("");
  auto r = encode_gaussian_ply(c);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("Gaussian 2 has a non-finite 'opacity'"), std::string::npos) << r.message();

  c = make_cloud(3, 3);
  c.sh_degree = 4;
  r = encode_gaussian_ply(c);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("SH degree 4"), std::string::npos) << r.message();

  c = make_cloud(3, 1);
  c.gaussians[2].id = c.gaussians[0].id;
  PlyGaussianWriteOptions o;
  o.write_gaussian_id = true;
  r = encode_gaussian_ply(c, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("gaussian_id 1000 is used by more than one"), std::string::npos) << r.message();
}

TEST(PlyGaussian, WriteFileReplacesAtomicallyAndReportsBadPath) {
  const auto dir = test::output_dir();
  const auto path = dir / "ply_gaussian_write.ply";
  const GaussianCloud c = make_cloud(10, 3);
  ASSERT_TRUE(write_gaussian_ply(path, c).ok());
  auto back = read_gaussian_ply(path);
  ASSERT_TRUE(back.ok()) << back.message();
  expect_bit_equal(c, back->cloud, false, false, false);
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));

  // A failed encode leaves the good file untouched.
  GaussianCloud bad = c;
  bad.gaussians[0].position.x = INFINITY;
  EXPECT_FALSE(write_gaussian_ply(path, bad).ok());
  EXPECT_TRUE(read_gaussian_ply(path).ok());

  auto st = write_gaussian_ply(dir / "no_such_dir" / "x.ply", c);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("no_such_dir"), std::string::npos) << st.message();
  auto missing = read_gaussian_ply(dir / "does_not_exist.ply");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("does_not_exist.ply: file not found"), std::string::npos) << missing.message();
}

// ---- Real scenes ----------------------------------------------------------------------

void check_real_round_trip(const PlyGaussianScene& s) {
  for (PlyFormat f : {PlyFormat::BinaryLittleEndian, PlyFormat::Ascii}) {
    PlyGaussianWriteOptions o;
    o.format = f;
    const PlyGaussianScene back = round_trip(s.cloud, o);
    EXPECT_EQ(back.report.renormalized_quaternions, 0u);
    expect_bit_equal(s.cloud, back.cloud, true, true, true);
  }
}

TEST(PlyGaussianData, GuitarLoadsFastAndRoundTrips) {
  GAUSS_REQUIRE_DATA(path, "splats/guitar.ply");
  const Stopwatch watch;
  auto s = read_gaussian_ply(path);
  const auto [wall_ms, cpu_ms] = watch.elapsed_ms();
  ASSERT_TRUE(s.ok()) << s.message();
  std::printf("guitar.ply: %zu Gaussians loaded in %.1f ms wall, %.1f ms CPU\n", s->cloud.gaussians.size(), wall_ms,
              cpu_ms);
  EXPECT_EQ(s->cloud.gaussians.size(), 90854u);
  EXPECT_EQ(s->cloud.sh_degree, 0);
  EXPECT_TRUE(s->report.has_normals);
  EXPECT_FALSE(s->report.has_gaussian_id);
  EXPECT_EQ(s->report.format, PlyFormat::BinaryLittleEndian);
  // The README: 667 opacities were clamped to logit(1 - 0.5/255) = 6.232.
  std::size_t clamped = 0;
  for (const auto& g : s->cloud.gaussians) clamped += std::abs(g.opacity_logit - 6.2324f) < 1e-3f;
  EXPECT_GE(clamped, 667u);
  check_real_round_trip(*s);
}

TEST(PlyGaussianData, FruitDropsSh3NormalisesQuaternionsAndRoundTrips) {
  GAUSS_REQUIRE_DATA(path, "splats/fruit_drops_sh3.ply");
  auto s = read_gaussian_ply(path);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->cloud.gaussians.size(), 4721u);
  EXPECT_EQ(s->cloud.sh_degree, 3);
  // Raw trained quaternions have norms 0.60-1.93: nearly all get normalised.
  EXPECT_GT(s->report.renormalized_quaternions, 4000u);
  EXPECT_EQ(s->report.zero_quaternions, 0u);
  bool any_rest = false;
  for (const auto& g : s->cloud.gaussians) any_rest |= g.sh_rest[14] != glm::vec3(0.0f);
  EXPECT_TRUE(any_rest) << "degree-3 coefficients should carry data";
  check_real_round_trip(*s);
}

TEST(PlyGaussianData, MetalSplatterThreePoints) {
  GAUSS_REQUIRE_DATA(path, "splats/metalsplatter_3-points-from-train.ply");
  auto s = read_gaussian_ply(path);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->cloud.gaussians.size(), 3u);
  EXPECT_EQ(s->cloud.sh_degree, 3);
  for (const auto& g : s->cloud.gaussians)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::isfinite(g.position[k]));
  check_real_round_trip(*s);
}

TEST(PlyGaussian, OneMillionGaussiansLoad) {
  const GaussianCloud c = make_cloud(1000000, 0, 3);
  PlyGaussianWriteOptions o;
  o.write_gaussian_id = true;
  auto bytes = encode_gaussian_ply(c, o);
  ASSERT_TRUE(bytes.ok());
  const Stopwatch watch;
  auto s = parse_gaussian_ply(*bytes, "million.ply");
  const auto [wall_ms, cpu_ms] = watch.elapsed_ms();
  ASSERT_TRUE(s.ok()) << s.message();
  std::printf("1M Gaussians (%zu MB): parsed in %.1f ms wall, %.1f ms CPU\n", bytes->size() >> 20, wall_ms, cpu_ms);
  ASSERT_EQ(s->cloud.gaussians.size(), 1000000u);
  EXPECT_EQ(to_underlying(s->cloud.gaussians[999999].id), to_underlying(c.gaussians[999999].id));
  EXPECT_EQ(bits(s->cloud.gaussians[999999].opacity_logit), bits(c.gaussians[999999].opacity_logit));
}

}  // namespace
}  // namespace gauss
