// Camera path files: every malformed input names where it is wrong; poses interpolate
// between keyframes and jump at a cut; events come out in time order.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "gauss/client/camera_path.h"

namespace gauss::client {
namespace {

constexpr const char* kGood = R"({
  "camera": {"width": 64, "height": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24},
  "fps": 20,
  "keyframes": [
    {"t": 0, "eye": [0, 1, 0], "look_at": [0, 1, 5]},
    {"t": 2, "eye": [2, 1, 0], "look_at": [2, 1, 5]},
    {"t": 2, "eye": [9, 1, 9], "look_at": [9, 1, 20], "cut": true},
    {"t": 4, "eye": [9, 3, 9], "look_at": [9, 3, 20]}
  ],
  "events": [
    {"t": 3, "clear": true},
    {"t": 1, "query": {"class": "chair", "rho": 0.4}},
    {"t": 1.5, "query": {"instance": 7, "rho": 1}},
    {"t": 2.5, "mode": "immediate"}
  ],
  "settle_s": 12
})";

glm::dvec3 eye_of(const Camera& c) {
  const glm::dmat3 r(c.world_to_camera);
  return -(glm::transpose(r) * glm::dvec3(c.world_to_camera[3]));
}

TEST(CameraPath, ParsesAFullFile) {
  auto p = parse_camera_path(kGood, "good.json");
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_TRUE(p->intrinsics.has_value());
  EXPECT_EQ(p->intrinsics->width, 64u);
  EXPECT_EQ(p->fps, 20.0);
  EXPECT_EQ(p->settle_s, 12.0);
  EXPECT_EQ(p->duration(), 4.0);
  ASSERT_EQ(p->events.size(), 4u);
  EXPECT_EQ(p->events[0].kind, PathEventKind::ClassQuery);
  EXPECT_EQ(p->events[0].text, "chair");
  EXPECT_FLOAT_EQ(p->events[0].rho, 0.4f);
  EXPECT_EQ(p->events[1].kind, PathEventKind::InstanceQuery);
  EXPECT_EQ(p->events[1].instance, ObjectId{7});
  EXPECT_EQ(p->events[2].kind, PathEventKind::Mode);
  EXPECT_EQ(p->events[2].mode, PublishMode::Immediate);
  EXPECT_EQ(p->events[3].kind, PathEventKind::Clear);
}

TEST(CameraPath, InterpolatesAndJumpsAtACut) {
  auto p = parse_camera_path(kGood, "good.json");
  ASSERT_TRUE(p.ok());
  const CameraIntrinsics in = *p->intrinsics;
  EXPECT_NEAR(eye_of(p->camera_at(0.0, in)).x, 0.0, 1e-9);
  EXPECT_NEAR(eye_of(p->camera_at(1.0, in)).x, 1.0, 1e-9);  // halfway
  EXPECT_NEAR(eye_of(p->camera_at(1.999, in)).x, 1.999, 1e-9);
  EXPECT_NEAR(eye_of(p->camera_at(2.0, in)).x, 9.0, 1e-9);   // the cut: no blend towards it
  EXPECT_NEAR(eye_of(p->camera_at(3.0, in)).y, 2.0, 1e-9);
  EXPECT_NEAR(eye_of(p->camera_at(99.0, in)).y, 3.0, 1e-9);  // clamped to the end
  const Camera c = p->camera_at(0.5, in);
  EXPECT_EQ(c.width, 64u);
  EXPECT_EQ(c.fx, 50.0);
  // OpenCV camera looking along +z of the world here: the camera's z axis is world +z.
  const glm::dmat3 r(c.world_to_camera);
  EXPECT_NEAR((glm::transpose(r) * glm::dvec3(0, 0, 1)).z, 1.0, 1e-9);
}

struct BadCase {
  const char* text;
  const char* expect;  // must appear in the message
};

TEST(CameraPath, EveryBadInputNamesWhatIsWrong) {
  const BadCase cases[] = {
      {"{\n  \"keyframes\": [\n    {\"t\": 0,, }\n  ]\n}", "line 3"},
      {"[]", "(top level)"},
      {"{}", "keyframes"},
      {R"({"keyframes": []})", "keyframes"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 1], "look_at": [0, 0, 1]}]})", "keyframes[0].eye"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}, {"t": 1, "eye": [0, "x", 0], "look_at": [0, 0, 1]}]})",
       "keyframes[1].eye[1]"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 0]}]})", "coincide"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 5, 0]}]})", "parallel to up"},
      {R"({"keyframes": [{"t": 2, "eye": [0, 0, 0], "look_at": [0, 0, 1]}, {"t": 1, "eye": [0, 0, 0], "look_at": [0, 0, 1]}]})",
       "keyframes[1].t"},
      {R"({"keyframes": [{"t": -1, "eye": [0, 0, 0], "look_at": [0, 0, 1]}]})", "keyframes[0].t"},
      {R"({"keyframes": [{"eye": [0, 0, 0], "look_at": [0, 0, 1]}]})", "keyframes[0].t"},
      {R"({"camera": {"width": 0, "height": 4, "fx": 1, "fy": 1, "cx": 0, "cy": 0}, "keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}]})",
       "camera.width"},
      {R"({"camera": {"width": 4, "height": 4, "fx": -1, "fy": 1, "cx": 0, "cy": 0}, "keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}]})",
       "camera.fx"},
      {R"({"fps": 0, "keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}]})", "fps"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}], "events": [{"t": 0, "jump": 1}]})",
       "events[0]"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}], "events": [{"t": 0, "query": {"class": "x", "rho": 2}}]})",
       "events[0].query.rho"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}], "events": [{"t": 0, "query": {"rho": 0.5}}]})",
       "events[0].query"},
      {R"({"keyframes": [{"t": 0, "eye": [0, 0, 0], "look_at": [0, 0, 1]}], "events": [{"t": 0, "mode": "fast"}]})",
       "events[0].mode"},
  };
  for (const BadCase& c : cases) {
    auto p = parse_camera_path(c.text, "bad.json");
    ASSERT_FALSE(p.ok()) << c.text;
    EXPECT_NE(p.message().find(c.expect), std::string::npos) << "message: " << p.message() << "\nexpected: " << c.expect;
    EXPECT_EQ(p.message().rfind("bad.json", 0), 0u) << p.message();
  }
  EXPECT_FALSE(read_camera_path("/nonexistent/path.json").ok());
}

}  // namespace
}  // namespace gauss::client
