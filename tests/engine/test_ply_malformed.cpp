// Malformed Gaussian PLY inputs: each must fail (never a partial cloud) with a message that
// names the input and says what and where (property, vertex, byte offset or line).
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/ply_gaussian.h"
#include "text_file.h"

namespace gauss {
namespace {

constexpr const char* kRequired[] = {"x",       "y",       "z",       "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                                     "scale_0", "scale_1", "scale_2", "rot_0",  "rot_1",  "rot_2",  "rot_3"};

std::string props(const std::vector<std::string>& names, const std::string& type = "float") {
  std::string s;
  for (const auto& n : names) s += "property " + type + " " + n + "\n";
  return s;
}

std::vector<std::string> required() { return {std::begin(kRequired), std::end(kRequired)}; }

std::string header(const std::string& format, std::size_t n, const std::string& body) {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(n) + "\n" + body + "end_header\n";
}

// Binary LE vertices of the 14 required floats; `poke(v, k)` may replace value k of vertex v.
std::vector<std::uint8_t> binary_file(std::size_t n, const std::string& extra_header = "",
                                      float (*poke)(std::size_t, int) = nullptr, std::size_t extra_bytes = 0) {
  std::vector<std::uint8_t> b = test::bytes_of(header("binary_little_endian", n, props(required()) + extra_header));
  for (std::size_t v = 0; v < n; ++v)
    for (int k = 0; k < 14; ++k) {
      float f = k == 10 ? 1.0f : 0.25f * float(k);
      if (poke) f = poke(v, k);
      std::uint8_t raw[4];
      std::memcpy(raw, &f, 4);
      b.insert(b.end(), raw, raw + 4);
    }
  b.insert(b.end(), extra_bytes, std::uint8_t{0});
  return b;
}

std::string ascii_line(const std::string& override_values = "") {
  return override_values.empty() ? "0 0 0 0 0 0 0 0 0 0 1 0 0 0\n" : override_values + "\n";
}

struct Case {
  const char* label;
  std::vector<std::uint8_t> bytes;
  std::vector<std::string> fragments;  // all must appear in the message
};

std::vector<Case> cases() {
  std::vector<Case> c;
  c.push_back({"empty", {}, {"bad.ply: ", "empty file"}});
  c.push_back({"not_ply", test::bytes_of("PLY\nformat ascii 1.0\n"), {"not a PLY file", "'PLY'"}});
  c.push_back({"truncated_header", test::bytes_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"),
               {"truncated header", "end_header"}});
  c.push_back({"header_cut_mid_line", test::bytes_of("ply\nformat ascii 1.0\nelement vert"),
               {"the file ends inside header line 3"}});
  c.push_back({"unknown_format", test::bytes_of("ply\nformat binary_middle_endian 1.0\nend_header\n"),
               {"header line 2", "unsupported format 'binary_middle_endian'"}});
  c.push_back({"bad_version", test::bytes_of("ply\nformat ascii 2.0\nend_header\n"), {"format version '2.0'"}});
  c.push_back({"unknown_type", test::bytes_of(header("ascii", 1, "property float16 x\n")),
               {"header line 4", "unknown type 'float16' for property 'x'"}});
  c.push_back({"property_before_element", test::bytes_of("ply\nformat ascii 1.0\nproperty float x\nend_header\n"),
               {"header line 3", "'property' before any 'element'"}});
  c.push_back({"element_before_format", test::bytes_of("ply\nelement vertex 1\nformat ascii 1.0\nend_header\n"),
               {"'element' before the 'format' line"}});
  c.push_back({"duplicate_property",
               test::bytes_of(header("ascii", 1, props(required()) + "property float opacity\n") + ascii_line()),
               {"duplicate property 'opacity' in element 'vertex'"}});
  {
    auto names = required();
    names.erase(names.begin() + 6);  // opacity
    c.push_back({"missing_opacity", test::bytes_of(header("ascii", 0, props(names))),
                 {"missing required vertex property 'opacity'"}});
  }
  {
    std::vector<std::string> rest;
    for (int k = 0; k < 10; ++k) rest.push_back("f_rest_" + std::to_string(k));
    c.push_back({"rest_count_10", test::bytes_of(header("ascii", 0, props(required()) + props(rest))),
                 {"found 10 f_rest properties", "0, 9, 24 or 45"}});
    rest.erase(rest.begin() + 3);  // 9 props but f_rest_3 missing, f_rest_9 present
    c.push_back({"rest_gap", test::bytes_of(header("ascii", 0, props(required()) + props(rest))),
                 {"missing vertex property 'f_rest_3'"}});
  }
  c.push_back({"rest_beyond_degree3", test::bytes_of(header("ascii", 0, props(required()) + props({"f_rest_45"}))),
               {"'f_rest_45'", "beyond SH degree 3"}});
  {
    // Count says 3 but the data holds 2.5 vertices: caught before decoding, naming the offset.
    auto b = binary_file(3);
    b.erase(b.end() - 28, b.end());
    c.push_back({"short_data", b, {"element 'vertex' declares 3 items", "byte offset", "truncated"}});
  }
  c.push_back({"trailing_bytes", binary_file(2, "", nullptr, 5), {"5 trailing bytes", "byte offset"}});
  c.push_back({"count_1e12", binary_file(1, "", nullptr, 0), {}});  // replaced below
  {
    std::string h = header("binary_little_endian", 0, props(required()));
    h.replace(h.find("vertex 0"), 8, "vertex 1000000000000");
    c.back() = {"count_1e12", test::bytes_of(h), {"count 1000000000000 exceeds the limit"}};
    std::string h2 = header("binary_little_endian", 0, props(required()));
    h2.replace(h2.find("vertex 0"), 8, "vertex 4000000000");
    c.push_back({"count_4e9", test::bytes_of(h2), {"declares 4000000000 items of at least 56 bytes", "only 0 bytes"}});
  }
  c.push_back({"count_not_integer", test::bytes_of("ply\nformat ascii 1.0\nelement vertex 12abc\nend_header\n"),
               {"count '12abc' is not a non-negative integer"}});
  // A vertex with a NaN or Inf is left out (NonFiniteVerticesAreLeftOut below); a file with
  // nothing else is an error that names the first.
  c.push_back({"every_vertex_nan", binary_file(5, "", [](std::size_t v, int k) {
                 return (v == 0 && k == 6) || (v > 0 && k == 8) ? std::numeric_limits<float>::quiet_NaN() : (k == 10 ? 1.0f : 0.0f);
               }),
               {"every one of its 5 vertices has a non-finite value", "the first: vertex 0, property 'opacity'",
                "byte offset " + std::to_string(header("binary_little_endian", 5, props(required())).size() + 6 * 4), "NaN"}});
  c.push_back({"every_vertex_inf_ascii", test::bytes_of(header("ascii", 2, props(required())) + ascii_line("0 -inf 0 0 0 0 0 0 0 0 1 0 0 0") + ascii_line("inf 0 0 0 0 0 0 0 0 0 1 0 0 0")),
               {"every one of its 2 vertices", "vertex 0, property 'y' (line 19)", "-Inf"}});
  c.push_back({"ascii_not_a_number", test::bytes_of(header("ascii", 1, props(required())) + ascii_line("0 0 0 0 0 0 zero 0 0 0 1 0 0 0")),
               {"vertex 0, property 'opacity' (line 19)", "'zero' is not a valid float"}});
  c.push_back({"ascii_too_few", test::bytes_of(header("ascii", 1, props(required())) + ascii_line("0.5 0.5 0.5 0.5 0.5 0.5 0.5 0.5 0.5 0.5 1 0 0")),
               {"vertex 0, property 'rot_3'", "too few values"}});
  c.push_back({"ascii_too_many", test::bytes_of(header("ascii", 1, props(required())) + ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 7")),
               {"vertex 0", "unexpected extra value '7'"}});
  // Wide values, so the data is long enough for 3 vertices by size and fails on line count.
  const std::string wide = ascii_line("0.25 0.25 0.25 0.25 0.25 0.25 0.25 0.25 0.25 0.25 1 0 0 0");
  c.push_back({"ascii_truncated", test::bytes_of(header("ascii", 3, props(required())) + wide + wide),
               {"vertex 2", "file ends at line 21"}});
  c.push_back({"ascii_trailing", test::bytes_of(header("ascii", 1, props(required())) + ascii_line() + ascii_line()),
               {"unexpected data after the last element at line 20"}});
  c.push_back({"header_line_too_long", test::bytes_of("ply\nformat ascii 1.0\ncomment " + std::string(5000, 'a') + "\nend_header\n"),
               {"header line 3", "longer than 4096 bytes"}});
  {
    std::string huge_line;
    for (int k = 0; k < 600000; ++k) huge_line += "0 ";
    c.push_back({"ascii_line_too_long", test::bytes_of(header("ascii", 1, props(required())) + huge_line + "\n"),
                 {"vertex 0 (line 19)", "line 19 is longer than 1048576 bytes"}});
  }
  c.push_back({"object_id_out_of_range",
               test::bytes_of(header("ascii", 1, props(required()) + "property int object_id\n") + ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 -5")),
               {"vertex 0, property 'object_id'", "object id -5 is out of range"}});
  c.push_back({"object_id_fraction",
               test::bytes_of(header("ascii", 1, props(required()) + "property float object_id\n") + ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 3.5")),
               {"property 'object_id'", "3.5", "not an integer"}});
  c.push_back({"support_negative",
               test::bytes_of(header("ascii", 1, props(required()) + "property int support\n") + ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 -2")),
               {"property 'support'", "negative value -2"}});
  c.push_back({"duplicate_gaussian_id",
               test::bytes_of(header("ascii", 3, props(required()) + "property uint gaussian_id\n") +
                        ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 7") + ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 8") +
                        ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 7")),
               {"gaussian_id 7 appears at vertex 0 and vertex 2"}});
  c.push_back({"double_out_of_float_range",
               test::bytes_of(header("ascii", 1, props({"x"}, "double") + props({"y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                                                                             "scale_0", "scale_1", "scale_2", "rot_0",
                                                                             "rot_1", "rot_2", "rot_3"})) +
                        ascii_line("1e300 0 0 0 0 0 0 0 0 0 1 0 0 0")),
               {"vertex 0, property 'x'", "outside the float range"}});
  c.push_back({"uchar_out_of_range",
               test::bytes_of(header("ascii", 1, props(required()) + "property uchar red\n") + ascii_line("0 0 0 0 0 0 0 0 0 0 1 0 0 0 300")),
               {"property 'red'", "'300' is out of range for type uchar"}});
  c.push_back({"element_without_properties",
               test::bytes_of("ply\nformat ascii 1.0\nelement junk 5\n" + header("ascii", 0, props(required())).substr(21)),
               {"element 'junk'", "declares 5 items but no properties"}});
  c.push_back({"list_position", test::bytes_of(header("ascii", 0, "property list uchar float x\n" + props({"y", "z"}))),
               {"vertex property 'x'", "is a list"}});
  c.push_back({"float_list_count", test::bytes_of(header("ascii", 0, "property list float int idx\n")),
               {"list count type 'float' is not an integer type"}});
  c.push_back({"no_vertex_element", test::bytes_of("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n"),
               {"no 'vertex' element"}});
  {
    // A skipped element whose list runs past the end of the data.
    std::string h = "ply\nformat binary_little_endian 1.0\nelement extra 1\nproperty list uchar int stuff\n" +
                    header("binary_little_endian", 0, props(required())).substr(36);
    auto b = test::bytes_of(h);
    b.push_back(200);  // 200 ints announced, 4 bytes present
    b.insert(b.end(), 4, std::uint8_t{1});
    c.push_back({"skipped_list_truncated", b, {"element 'extra' item 0, property 'stuff'", "file ends at byte offset"}});
  }
  c.push_back({"binary_garbage_name", test::bytes_of("ply\nformat ascii 1.0\nelement ver\x01tex 1\nend_header\n"),
               {"non-printable", "\\x01"}});
  c.push_back({"no_newline_after_end_header", test::bytes_of("ply\nformat ascii 1.0\nend_header"),
               {"truncated header: the file ends inside header line 3"}});
  return c;
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.label; }

class PlyMalformed : public ::testing::TestWithParam<Case> {};

TEST_P(PlyMalformed, FailsWithSpecificMessage) {
  const Case& c = GetParam();
  auto r = parse_gaussian_ply(c.bytes, "bad.ply");
  ASSERT_FALSE(r.ok()) << c.label << " was accepted";
  EXPECT_EQ(r.message().rfind("bad.ply: ", 0), 0u) << r.message();
  for (const auto& f : c.fragments) EXPECT_NE(r.message().find(f), std::string::npos) << "want '" << f << "' in: " << r.message();
}

INSTANTIATE_TEST_SUITE_P(Cases, PlyMalformed, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& param_info) { return std::string(param_info.param.label); });

TEST(PlyNonFinite, NonFiniteVerticesAreLeftOutAndListedTheRestKeepTheirIds) {
  // Six vertices: 1 has a NaN x, 3 an infinite scale_1, 4 and 5 infinite opacity logits
  // (saturated opacities: clamped, kept), 2 a NaN f_dc_2 in the ASCII copy.
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN(), kInf = std::numeric_limits<float>::infinity();
  const auto bytes = binary_file(6, "", [](std::size_t v, int k) {
    if (v == 1 && k == 0) return kNaN;
    if (v == 3 && k == 8) return kInf;
    if (v == 4 && k == 6) return -kInf;
    if (v == 5 && k == 6) return kInf;
    return k == 10 ? 1.0f : 0.1f * float(v);
  });
  auto r = parse_gaussian_ply(bytes, "six.ply");
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_EQ(r->report.vertex_count, 6u);
  EXPECT_EQ(r->report.dropped_vertices, (std::vector<std::size_t>{1, 3}));
  const std::size_t data = header("binary_little_endian", 6, props(required())).size();
  EXPECT_EQ(r->report.first_dropped,
            "vertex 1, property 'x' (byte offset " + std::to_string(data + 56) + "): value is NaN");
  EXPECT_EQ(r->report.saturated_opacities, 2u);
  ASSERT_EQ(r->cloud.gaussians.size(), 4u);
  const std::uint64_t kept[] = {0, 2, 4, 5};
  for (std::size_t i = 0; i < 4; ++i) {
    const Gaussian& g = r->cloud.gaussians[i];
    EXPECT_EQ(to_underlying(g.id), kept[i]) << "ids stay the vertex index";
    EXPECT_FLOAT_EQ(g.position.y, 0.1f * float(kept[i])) << i;
  }
  const float ln509 = float(std::log(509.0));
  EXPECT_NEAR(r->cloud.gaussians[2].opacity_logit, -ln509, 1e-5);
  EXPECT_NEAR(r->cloud.gaussians[3].opacity_logit, ln509, 1e-5);

  // ASCII: the first value left out is named by its line; a NaN in any float counts.
  const std::string ascii = header("ascii", 3, props(required())) + ascii_line() +
                            ascii_line("0 0 0 0 0 nan 0 0 0 0 1 0 0 0") + ascii_line("0 0 1 0 0 0 0 0 0 0 1 0 0 0");
  auto a = parse_gaussian_ply(test::bytes_of(ascii), "three.ply");
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_EQ(a->report.dropped_vertices, (std::vector<std::size_t>{1}));
  EXPECT_EQ(a->report.first_dropped, "vertex 1, property 'f_dc_2' (line 20): value is NaN");
  ASSERT_EQ(a->cloud.gaussians.size(), 2u);
  EXPECT_EQ(a->cloud.gaussians[1].id, GaussianId{2});
  EXPECT_EQ(a->cloud.gaussians[1].position.z, 1.0f);
}

TEST(PlyNonFinite, ARepeatedIdIsNamedByItsVertexInTheFile) {
  // gaussian_id 7 at vertices 0 and 3, vertex 1 left out: the message counts file vertices.
  std::string text = header("ascii", 4, props(required()) + "property uint gaussian_id\n");
  text += "0 0 0 0 0 0 0 0 0 0 1 0 0 0 7\n0 nan 0 0 0 0 0 0 0 0 1 0 0 0 8\n0 0 0 0 0 0 0 0 0 0 1 0 0 0 9\n"
          "0 0 0 0 0 0 0 0 0 0 1 0 0 0 7\n";
  auto r = parse_gaussian_ply(test::bytes_of(text), "ids.ply");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("gaussian_id 7 appears at vertex 0 and vertex 3"), std::string::npos) << r.message();
}

TEST(PlyMalformedCount, AtLeastFifteenCases) { EXPECT_GE(cases().size(), 15u); }

TEST(PlyMalformedCount, HugeCountFailsFast) {
  // A 4e9-vertex header over a few bytes must fail before allocating anything.
  std::string h = header("binary_little_endian", 0, props(required()));
  h.replace(h.find("vertex 0"), 8, "vertex 4000000000");
  const auto b = test::bytes_of(h + std::string(100, '\0'));
  const auto t0 = std::chrono::steady_clock::now();
  auto r = parse_gaussian_ply(b, "huge.ply");
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_FALSE(r.ok());
  EXPECT_LT(ms, 500.0);
}

TEST(PlyMalformedCount, EveryPrefixOfAValidFileFailsCleanly) {
  // Truncation at every byte: never accepted as a smaller scene, never a crash.
  const auto b = binary_file(3, "property int object_id\n", nullptr, 3 * 4);
  ASSERT_TRUE(parse_gaussian_ply(b, "full.ply").ok());
  for (std::size_t n = 0; n < b.size(); ++n) {
    auto r = parse_gaussian_ply(std::span<const std::uint8_t>(b.data(), n), "cut.ply");
    EXPECT_FALSE(r.ok()) << "prefix of " << n << " bytes accepted";
  }
}

}  // namespace
}  // namespace gauss
