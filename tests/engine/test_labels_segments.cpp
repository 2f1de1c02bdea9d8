// Per-Gaussian labels from a segments.ai point-cloud segmentation export (labels_io.h): the
// real fruit_drops export gives the same labels as its text file and, read as an object
// table, names every label it uses; hand-made exports cover annotation -> category mapping
// and every refusal.
#include <algorithm>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "gauss/engine/labels_io.h"
#include "gauss/engine/objects_json.h"
#include "test_data.h"

namespace gauss {
namespace {

std::string export_with(const std::string& annotations, const std::string& points) {
  return R"({"dataset": {"task_attributes": {"categories": [{"id": 1, "name": "chair"}, {"id": 2, "name": "table"}]},
    "samples": [{"name": "s.ply", "labels": {"ground-truth": {"attributes": {"annotations": )" +
         annotations + R"(, "point_annotations": )" + points + "}}}}]}}";
}

TEST(LabelsSegmentsAi, RealExportMatchesItsLabelFile) {
  GAUSS_REQUIRE_DATA(json_path, "semantic/fruit_drops_segments.json");
  GAUSS_REQUIRE_DATA(txt_path, "semantic/fruit_drops_labels.txt");
  auto from_json = read_labels(json_path);
  auto from_txt = read_labels(txt_path);
  ASSERT_TRUE(from_json.ok()) << from_json.message();
  ASSERT_TRUE(from_txt.ok()) << from_txt.message();
  ASSERT_EQ(from_json->size(), 4721u);
  EXPECT_EQ(*from_json, *from_txt);
  auto objects = read_objects_json(json_path);
  ASSERT_TRUE(objects.ok()) << objects.message();
  std::set<std::int32_t> named;
  for (const ObjectLabel& o : *objects) named.insert(static_cast<std::int32_t>(o.id));
  for (std::int32_t l : *from_json) {
    if (l == 0) continue;
    EXPECT_TRUE(named.count(l)) << "label " << l << " has no object table entry";
  }
}

TEST(LabelsSegmentsAi, PointsTakeTheirAnnotationsCategory) {
  // Annotations 7 and 9 are two chairs (category 1), 8 a table (category 2).
  const auto text = export_with(R"([{"id": 7, "category_id": 1}, {"id": 8, "category_id": 2}, {"id": 9, "category_id": 1}])",
                                "[0, 7, 8.0, 9, 0]");
  auto l = parse_labels(text, "hand.json");
  ASSERT_TRUE(l.ok()) << l.message();
  EXPECT_EQ(*l, (std::vector<std::int32_t>{0, 1, 2, 1, 0}));
}

TEST(LabelsSegmentsAi, BadExportsAreClearErrors) {
  const std::string ann = R"([{"id": 1, "category_id": 1}])";
  const struct {
    std::string text, expect;
  } cases[] = {
      {export_with(ann, "[0, 2]"), "annotation 2"},
      {export_with(ann, "[0, 1.5]"), "point_annotations[1]"},
      {export_with(ann, "[0, -1]"), "point_annotations[1]"},
      {export_with(ann, R"([0, "1"])"), "point_annotations[1]"},
      {export_with(R"([{"id": 1}])", "[1]"), "annotations[0]"},
      {R"({"dataset": {"samples": []}})", "no dataset.samples"},
      {R"({"dataset": {"samples": [{"labels": {}}]}})", "no labels"},
      {R"({"dataset": {"samples": [{"labels": {"gt": {"attributes": {}}}}]}})", "point_annotations"},
      {"{\"dataset\": ", "malformed JSON at byte"},
  };
  for (const auto& c : cases) {
    auto l = parse_labels(c.text, "bad.json");
    ASSERT_FALSE(l.ok()) << c.text;
    EXPECT_NE(l.message().find("bad.json"), std::string::npos) << l.message();
    EXPECT_NE(l.message().find(c.expect), std::string::npos) << l.message();
  }
}

}  // namespace
}  // namespace gauss
