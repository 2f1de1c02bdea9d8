// Camera JSON: row-major file <-> column-major glm, validation messages, exact round trip.
#include <cmath>
#include <cstring>
#include <string>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include <gtest/gtest.h>

#include "gauss/engine/camera_io.h"
#include "test_data.h"

namespace gauss {
namespace {

// 90 degrees about z (not symmetric, so a missing transpose shows) with translation (1, 2, 3).
const char* kRotated = R"({
  "width": 320, "height": 180, "fx": 386.2741699796952, "fy": 386.2741699796952, "cx": 160.0, "cy": 90.0,
  "world_to_camera": [[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]]
})";

std::string with_matrix(const std::string& rows, const std::string& extra = "") {
  return R"({"width": 64, "height": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24, )" + extra +
         R"("world_to_camera": )" + rows + "}";
}
const std::string kIdentityRows = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";

TEST(CameraIo, ReadsRowMajorIntoColumnMajor) {
  auto c = parse_camera_json(kRotated, "rot.json");
  ASSERT_TRUE(c.ok()) << c.message();
  EXPECT_EQ(c->width, 320u);
  EXPECT_EQ(c->height, 180u);
  EXPECT_EQ(c->fx, 386.2741699796952);
  EXPECT_EQ(c->cy, 90.0);
  // GLM is m[column][row]: file row 0 = [0, -1, 0, 1] is m[0][0], m[1][0], m[2][0], m[3][0].
  EXPECT_EQ(c->world_to_camera[1][0], -1.0);
  EXPECT_EQ(c->world_to_camera[0][1], 1.0);
  EXPECT_EQ(c->world_to_camera[3][0], 1.0);
  EXPECT_EQ(c->world_to_camera[3][1], 2.0);
  EXPECT_EQ(c->world_to_camera[3][2], 3.0);
  // The world x axis maps to camera y; the world origin to the translation.
  const glm::dvec4 x = c->world_to_camera * glm::dvec4(1, 0, 0, 1);
  EXPECT_EQ(x, glm::dvec4(1, 3, 3, 1));
  const glm::dvec4 o = c->world_to_camera * glm::dvec4(0, 0, 0, 1);
  EXPECT_EQ(o, glm::dvec4(1, 2, 3, 1));
  // Defaults when near/far are absent.
  EXPECT_EQ(c->near_plane, Camera{}.near_plane);
  EXPECT_EQ(c->far_plane, Camera{}.far_plane);
}

TEST(CameraIo, ReadsTheBenchCameraFile) {
  auto dir = test::data_dir();
  if (!dir || !std::filesystem::exists(*dir / ".." / "bench" / "box_camera_320x180.json"))
    GTEST_SKIP() << "shared bench/box_camera_320x180.json not found beside the data folder";
  auto c = read_camera_json(*dir / ".." / "bench" / "box_camera_320x180.json");
  ASSERT_TRUE(c.ok()) << c.message();
  EXPECT_EQ(c->width, 320u);
  EXPECT_EQ(c->height, 180u);
  EXPECT_EQ(c->world_to_camera[1][1], -1.0);
  EXPECT_EQ(c->world_to_camera[2][2], -1.0);
}

TEST(CameraIo, WriteReadRoundTripIsExact) {
  Camera c;
  c.width = 1280;
  c.height = 720;
  c.fx = 1000.0 / 3.0;
  c.fy = 1000.0 / 7.0;
  c.cx = 640.1234567890123;
  c.cy = 359.9;
  c.near_plane = 0.0123456789;
  c.far_plane = 123.456;
  const glm::dquat q = glm::normalize(glm::dquat(0.3, -0.4, 0.5, 0.7));
  const glm::dmat3 r = glm::mat3_cast(q);
  c.world_to_camera = glm::dmat4(r);
  c.world_to_camera[3] = glm::dvec4(0.1, -2.0 / 3.0, 1e-9, 1.0);
  auto text = camera_to_json(c);
  ASSERT_TRUE(text.ok()) << text.message();
  auto back = parse_camera_json(*text, "roundtrip.json");
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(back->width, c.width);
  EXPECT_EQ(back->height, c.height);
  EXPECT_EQ(back->fx, c.fx);
  EXPECT_EQ(back->fy, c.fy);
  EXPECT_EQ(back->cx, c.cx);
  EXPECT_EQ(back->cy, c.cy);
  EXPECT_EQ(back->near_plane, c.near_plane);
  EXPECT_EQ(back->far_plane, c.far_plane);
  EXPECT_EQ(std::memcmp(&back->world_to_camera, &c.world_to_camera, sizeof(glm::dmat4)), 0);
  // The file is row-major: the first row holds r[0][0], r[1][0], r[2][0], tx.
  EXPECT_NE(text->find("\"world_to_camera\""), std::string::npos);

  const auto path = test::output_dir() / "camera_io_roundtrip.json";
  ASSERT_TRUE(write_camera_json(path, c).ok());
  auto from_file = read_camera_json(path);
  ASSERT_TRUE(from_file.ok()) << from_file.message();
  EXPECT_EQ(std::memcmp(&from_file->world_to_camera, &c.world_to_camera, sizeof(glm::dmat4)), 0);
}

TEST(CameraIo, RejectsBadCamerasWithSpecificMessages) {
  struct Bad {
    std::string text;
    std::string fragment;
  };
  const Bad cases[] = {
      {"{", "invalid JSON"},
      {"[1, 2]", "expected a JSON object, got array"},
      {with_matrix("[[1.01,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]"),
       "rotation is not orthonormal: max |R^T R - I| = 0.0201 (tolerance 0.0001)"},
      {with_matrix("[[1,0,0,0],[0,1,0,0],[0,0,-1,0],[0,0,0,1]]"), "determinant -1 (a reflection"},
      {with_matrix("[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]"), "bottom row must be 0 0 0 1, got 0 0 1 1"},
      {with_matrix("[[1,0,0,0],[0,1,0,0],[0,0,1,0]]"), "4x4 row-major matrix"},
      {with_matrix("[[1,0,0,0],[0,1,0],[0,0,1,0],[0,0,0,1]]"), "(row 1)"},
      {with_matrix("[[1,0,0,0],[0,1,0,\"a\"],[0,0,1,0],[0,0,0,1]]"), "world_to_camera[1][3] is not a number"},
      {with_matrix(kIdentityRows, R"("near": 0, )"), "near must be finite and > 0, got 0"},
      {with_matrix(kIdentityRows, R"("near": 5, "far": 2, )"), "far (2) must be finite and greater than near (5)"},
      {with_matrix(kIdentityRows, R"("far": 1e400, )"), "invalid JSON"},
      {R"({"width": 0, "height": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24, "world_to_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
       "key 'width' must be an integer in 1..65536, got 0"},
      {R"({"width": 64.5, "height": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24, "world_to_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
       "key 'width' must be an integer"},
      {R"({"width": 64, "height": 48, "fx": -50, "fy": 50, "cx": 32, "cy": 24, "world_to_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
       "fx must be finite and > 0, got -50"},
      {R"({"width": 64, "height": 48, "fy": 50, "cx": 32, "cy": 24, "world_to_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
       "missing key 'fx'"},
      {R"({"width": 64, "height": 48, "fx": "50", "fy": 50, "cx": 32, "cy": 24, "world_to_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
       "key 'fx' must be a number, got string"},
      {R"({"width": 64, "height": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24})", "missing key 'world_to_camera'"},
  };
  for (const auto& c : cases) {
    auto r = parse_camera_json(c.text, "cam.json");
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_EQ(r.message().rfind("cam.json: ", 0), 0u) << r.message();
    EXPECT_NE(r.message().find(c.fragment), std::string::npos) << "want '" << c.fragment << "' in: " << r.message();
  }
}

TEST(CameraIo, SmallRotationNoiseIsAcceptedBottomRowStoredExactly) {
  auto c = parse_camera_json(with_matrix("[[1.00002,0,0,0],[0,1,0,0],[0,0,1,0],[1e-12,0,0,1]]"), "noisy.json");
  ASSERT_TRUE(c.ok()) << c.message();
  EXPECT_EQ(c->world_to_camera[0][3], 0.0);
}

TEST(CameraIo, WriterAndValidatorRejectInvalidCameras) {
  Camera c;
  c.width = 10;
  c.height = 10;
  c.fx = c.fy = 5;
  c.world_to_camera[0][0] = NAN;
  auto r = camera_to_json(c);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("world_to_camera[0][0] is not finite"), std::string::npos) << r.message();
  c.world_to_camera = glm::dmat4(1.0);
  c.fx = 0;
  EXPECT_FALSE(validate_camera(c, "c").ok());
  auto missing = read_camera_json(test::output_dir() / "no_camera_here.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("no_camera_here.json: file not found"), std::string::npos);
}

}  // namespace
}  // namespace gauss
