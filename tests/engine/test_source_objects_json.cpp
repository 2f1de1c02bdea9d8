// Objects JSON sidecar: the three accepted forms and clear errors for bad input.
#include <gtest/gtest.h>

#include "gauss/engine/objects_json.h"
#include "test_data.h"

namespace gauss {
namespace {

TEST(ObjectsJson, ArrayForm) {
  auto r = parse_objects_json(R"({"objects": [{"id": 7, "label": "table"}, {"id": 3, "label": "chair", "quality": 0.25}]})",
                              "a.json");
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].id, ObjectId{3});  // sorted by id
  EXPECT_EQ((*r)[0].label, "chair");
  EXPECT_FLOAT_EQ((*r)[0].quality, 0.25f);
  EXPECT_EQ((*r)[1].label, "table");
  EXPECT_FLOAT_EQ((*r)[1].quality, 1.0f);
}

TEST(ObjectsJson, MapForm) {
  auto r = parse_objects_json(R"({"12": "robot_arm", "4": "plant"})", "m.json");
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].id, ObjectId{4});
  EXPECT_EQ((*r)[1].label, "robot_arm");
}

TEST(ObjectsJson, Errors) {
  const auto bad = [](const char* text, const char* needle) {
    auto r = parse_objects_json(text, "bad.json");
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.message().find("bad.json"), std::string::npos) << r.message();
    EXPECT_NE(r.message().find(needle), std::string::npos) << r.message();
  };
  bad(R"({"objects": [{"id": 1, "label": "a"},)", "byte");
  bad(R"([1, 2])", "top level");
  bad(R"({"objects": {"id": 1}})", "not an array");
  bad(R"({"objects": [{"id": 1}]})", "objects[0]");
  bad(R"({"objects": [{"id": -2, "label": "a"}]})", "negative");
  bad(R"({"objects": [{"id": 1.5, "label": "a"}]})", "not an integer");
  bad(R"({"objects": [{"id": 4294967296, "label": "a"}]})", "int32");
  bad(R"({"objects": [{"id": 1, "label": ""}]})", "empty");
  bad(R"({"objects": [{"id": 1, "label": 5}]})", "not a string");
  bad(R"({"objects": [{"id": 1, "label": "a", "quality": 2}]})", "quality");
  bad(R"({"objects": [{"id": 1, "label": "a"}, {"id": 1, "label": "b"}]})", "twice");
  bad(R"({"x1": "chair"})", "not an integer");
  bad("\xff\xfe", "malformed");
  auto missing = read_objects_json(test::output_dir() / "no_such_objects.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("no_such_objects.json"), std::string::npos);
}

TEST(ObjectsJson, SegmentsAiExport) {
  GAUSS_REQUIRE_DATA(path, "semantic/fruit_drops_segments.json");
  auto r = read_objects_json(path);
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_EQ(r->size(), 9u);
  EXPECT_EQ((*r)[0].id, ObjectId{1});
  EXPECT_EQ((*r)[0].label, "Category 1");
}

}  // namespace
}  // namespace gauss
