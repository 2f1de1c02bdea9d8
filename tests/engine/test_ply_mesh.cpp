// Mesh PLY reader/writer: round trips, index/count types, polygon splitting, bad input.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/ply_mesh.h"
#include "test_data.h"
#include "text_file.h"

namespace gauss {
namespace {

TriangleMesh make_mesh() {
  TriangleMesh m;
  for (int i = 0; i < 6; ++i) {
    m.positions.push_back(glm::vec3(0.1f * float(i), -1.0f / 3.0f * float(i), 1e-7f * float(i * i)));
    m.colors.push_back(glm::u8vec3(std::uint8_t(i * 40), std::uint8_t(255 - i), std::uint8_t(i)));
  }
  m.indices = {0, 1, 2, 2, 3, 4, 5, 4, 0};
  return m;
}

void expect_equal(const TriangleMesh& a, const TriangleMesh& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (std::size_t i = 0; i < a.positions.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.positions[i], &b.positions[i], sizeof(glm::vec3)), 0) << "vertex " << i;
    EXPECT_EQ(a.colors[i], b.colors[i]) << "vertex " << i;
  }
  EXPECT_EQ(a.indices, b.indices);
}

TEST(PlyMesh, RoundTripAllFormatsExact) {
  const TriangleMesh m = make_mesh();
  for (PlyFormat f : {PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian, PlyFormat::Ascii}) {
    auto bytes = encode_mesh_ply(m, {f});
    ASSERT_TRUE(bytes.ok()) << bytes.message();
    auto back = parse_mesh_ply(*bytes, "mesh.ply");
    ASSERT_TRUE(back.ok()) << back.message();
    expect_equal(m, back->mesh);
    EXPECT_TRUE(back->report.has_colors);
    EXPECT_EQ(back->report.polygon_count, 3u);
    EXPECT_EQ(back->report.format, f);
  }
}

TEST(PlyMesh, QuadsAndPolygonsAreFannedWithUintAndUshortIndices) {
  // Binary LE, vertex without colours, faces with "list uint uint" and "list uchar ushort" forms.
  struct Form {
    const char* list;
    int count_bytes;
    int index_bytes;
  };
  for (const Form form : {Form{"list uint uint", 4, 4}, Form{"list uchar ushort", 1, 2}, Form{"list ushort int", 2, 4}}) {
    SCOPED_TRACE(form.list);
    std::string h = std::string("ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\n") +
                    "property float y\nproperty float z\nproperty float nx\nelement face 2\nproperty " + form.list +
                    " vertex_indices\nproperty uchar flags\nend_header\n";
    std::vector<std::uint8_t> b = test::bytes_of(h);
    for (int i = 0; i < 5; ++i)
      for (int k = 0; k < 4; ++k) test::append_bytes<float>(b, float(i + k));
    auto put_le = [&](std::uint32_t v, int n) {
      for (int k = 0; k < n; ++k) b.push_back(std::uint8_t(v >> (8 * k)));
    };
    auto put_count = [&](std::uint32_t n) { put_le(n, form.count_bytes); };
    auto put_index = [&](std::uint32_t v) { put_le(v, form.index_bytes); };
    put_count(4);  // quad 0 1 2 3
    for (std::uint32_t v : {0u, 1u, 2u, 3u}) put_index(v);
    b.push_back(7);
    put_count(5);  // pentagon 4 3 2 1 0
    for (std::uint32_t v : {4u, 3u, 2u, 1u, 0u}) put_index(v);
    b.push_back(7);
    auto s = parse_mesh_ply(b, "quads.ply");
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_FALSE(s->report.has_colors);
    EXPECT_EQ(s->report.split_polygons, 2u);
    EXPECT_EQ(s->mesh.indices, (std::vector<std::uint32_t>{0, 1, 2, 0, 2, 3, 4, 3, 2, 4, 2, 1, 4, 1, 0}));
    ASSERT_EQ(s->mesh.colors.size(), 5u);
    EXPECT_EQ(s->mesh.colors[3], glm::u8vec3(255));
    EXPECT_EQ(s->mesh.positions[2], glm::vec3(2, 3, 4));
  }
}

TEST(PlyMesh, AsciiWithOtherElementsAndVertexIndexName) {
  const std::string ply =
      "ply\nformat ascii 1.0\ncomment from some tool\nelement vertex 3\nproperty double x\nproperty double y\n"
      "property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
      "element face 1\nproperty list uchar int vertex_index\nend_header\n"
      "0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n0 1\n3 0 1 2\n";
  auto s = parse_mesh_ply(test::bytes_of(ply), "ascii_mesh.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->mesh.indices, (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_EQ(s->mesh.colors[1], glm::u8vec3(0, 255, 0));
  EXPECT_EQ(s->mesh.positions[2], glm::vec3(0, 1, 0));
}

TEST(PlyMesh, PointOnlyFileHasNoTriangles) {
  auto s = parse_mesh_ply(test::bytes_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                   "property float z\nend_header\n1 2 3\n"),
                          "points.ply");
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->mesh.positions.size(), 1u);
  EXPECT_TRUE(s->mesh.indices.empty());
}

struct BadMesh {
  const char* label;
  std::string text;
  std::string fragment;
};

TEST(PlyMesh, MalformedInputsNameWhatAndWhere) {
  const std::string vhead = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string verts = "0 0 0\n1 0 0\n0 1 0\n";
  const std::string fhead = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::vector<BadMesh> cases = {
      {"index out of range", vhead + fhead + verts + "3 0 1 3\n", "face 0, property 'vertex_indices' (line 13): index 3 is out of range (the mesh has 3 vertices)"},
      {"negative index", vhead + fhead + verts + "3 0 -1 2\n", "index -1 is out of range"},
      {"two-vertex polygon", vhead + fhead + verts + "2 0 1\n", "face 0, property 'vertex_indices' (line 13): polygon has 2 vertices"},
      {"nan position", vhead + fhead + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "vertex 1, property 'y' (line 11): value is NaN"},
      {"missing z", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nend_header\n", "missing required vertex property 'z'"},
      {"partial colours", vhead + "property uchar red\nend_header\n0 0 0 0\n0 0 0 0\n0 0 0 0\n", "need all of 'red', 'green', 'blue'"},
      {"colour out of range", vhead + "property ushort red\nproperty uchar green\nproperty uchar blue\nend_header\n0 0 0 256 0 0\n0 0 0 0 0 0\n0 0 0 0 0 0\n",
       "vertex 0, property 'red' (line 11): colour 256 is outside 0..255"},
      {"face without indices", vhead + "element face 1\nproperty uchar flags\nend_header\n" + verts + "1\n", "element 'face' has no 'vertex_indices' list"},
      {"float indices", vhead + "element face 1\nproperty list uchar float vertex_indices\nend_header\n" + verts + "3 0 1 2\n", "item type float; expected an integer type"},
      {"short face data", vhead + fhead + verts + "4 0 1 2\n", "face 0, property 'vertex_indices' (line 13): line 13 has too few values"},
      {"trailing data", vhead + fhead + verts + "3 0 1 2\n3 0 1 2\n", "unexpected data after the last element at line 14"},
  };
  for (const auto& c : cases) {
    auto r = parse_mesh_ply(test::bytes_of(c.text), "bad_mesh.ply");
    ASSERT_FALSE(r.ok()) << c.label << " accepted";
    EXPECT_NE(r.message().find("bad_mesh.ply: "), std::string::npos) << r.message();
    EXPECT_NE(r.message().find(c.fragment), std::string::npos) << c.label << ": want '" << c.fragment << "' in: " << r.message();
  }
}

TEST(PlyMesh, BinaryTruncationAndTrailingBytes) {
  auto good = encode_mesh_ply(make_mesh());
  ASSERT_TRUE(good.ok());
  for (std::size_t n = 0; n < good->size(); ++n)
    EXPECT_FALSE(parse_mesh_ply(std::span<const std::uint8_t>(good->data(), n), "cut.ply").ok()) << n;
  auto longer = *good;
  longer.push_back(0);
  auto r = parse_mesh_ply(longer, "long.ply");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("1 trailing bytes after the last element (byte offset"), std::string::npos) << r.message();
}

TEST(PlyMesh, WriterRejectsInconsistentMeshes) {
  TriangleMesh m = make_mesh();
  m.colors.pop_back();
  auto r = encode_mesh_ply(m);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("5 colours for 6 vertices"), std::string::npos) << r.message();
  m = make_mesh();
  m.indices.push_back(1);
  r = encode_mesh_ply(m);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("10 indices is not a multiple of 3"), std::string::npos) << r.message();
  m = make_mesh();
  m.indices[4] = 6;
  r = encode_mesh_ply(m);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("index 4 (6) is out of range"), std::string::npos) << r.message();
  m = make_mesh();
  m.positions[2].z = NAN;
  r = encode_mesh_ply(m);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("vertex 2 has a non-finite position"), std::string::npos) << r.message();
  // No colours at all: written white.
  m = make_mesh();
  m.colors.clear();
  auto ok = encode_mesh_ply(m);
  ASSERT_TRUE(ok.ok());
  auto back = parse_mesh_ply(*ok, "white.ply");
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->mesh.colors[0], glm::u8vec3(255));
}

TEST(PlyMesh, WriteAndReadFile) {
  const auto path = test::output_dir() / "ply_mesh_write.ply";
  const TriangleMesh m = make_mesh();
  ASSERT_TRUE(write_mesh_ply(path, m).ok());
  auto back = read_mesh_ply(path);
  ASSERT_TRUE(back.ok()) << back.message();
  expect_equal(m, back->mesh);
}

}  // namespace
}  // namespace gauss
