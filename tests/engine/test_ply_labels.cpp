// Per-Gaussian label files (the semantic sidecar of a PLY scene) and the count check.
#include <array>
#include <string>

#include <gtest/gtest.h>

#include "gauss/engine/labels_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "test_data.h"

namespace gauss {
namespace {

TEST(Labels, ParsesIntegersWithCrlfSpacesAndNoFinalNewline) {
  auto r = parse_labels("0\n7\r\n -3 \n2147483647\n\t12", "l.txt");
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_EQ(*r, (std::vector<std::int32_t>{0, 7, -3, 2147483647, 12}));
  auto empty = parse_labels("", "empty.txt");
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
}

TEST(Labels, RejectsBadLinesNamingTheLine) {
  const std::array<std::pair<const char*, const char*>, 7> cases{{
      {"0\n1\n1.5\n", "l.txt: line 3: '1.5' is not an integer label"},
      {"0\nseven\n", "l.txt: line 2: 'seven' is not an integer label"},
      {"0\n4 5\n", "l.txt: line 2: '4 5' is not an integer label"},
      {"0\n\n1\n", "l.txt: line 2: empty line"},
      {"2147483648\n", "l.txt: line 1: label '2147483648' is outside the int32 range"},
      {"0\n0\n0\n7a\n", "l.txt: line 4: '7a' is not an integer label"},
      {"1\n0000000000000000000000000000000000000000000000000000000000000000000000001\n", "l.txt: line 2: longer than 64 bytes"},
  }};
  for (const auto& [text, fragment] : cases) {
    auto r = parse_labels(text, "l.txt");
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.message().find(fragment), std::string::npos) << "want '" << fragment << "' in: " << r.message();
  }
}

TEST(Labels, CountCheckNamesBothCounts) {
  const std::vector<std::int32_t> labels{1, 2, 3};
  EXPECT_TRUE(check_label_count(labels, 3, "a.txt", "b.ply").ok());
  auto st = check_label_count(labels, 4, "a.txt", "b.ply");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.message(), "a.txt has 3 labels but b.ply has 4 Gaussians");
}

TEST(LabelsData, FruitDropsLabelsMatchTheScene) {
  GAUSS_REQUIRE_DATA(labels_path, "semantic/fruit_drops_labels.txt");
  GAUSS_REQUIRE_DATA(scene_path, "splats/fruit_drops_sh3.ply");
  auto labels = read_labels(labels_path);
  ASSERT_TRUE(labels.ok()) << labels.message();
  auto scene = read_gaussian_ply(scene_path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  EXPECT_TRUE(check_label_count(*labels, scene->cloud.gaussians.size(), labels_path.string(), scene_path.string()).ok());
  // The README's histogram: 229/542/680/398/1038/616/396/556/266 Gaussians for labels 0..8.
  std::array<std::size_t, 9> hist{};
  for (std::int32_t l : *labels) {
    ASSERT_GE(l, 0);
    ASSERT_LE(l, 8);
    ++hist[static_cast<std::size_t>(l)];
  }
  EXPECT_EQ(hist, (std::array<std::size_t, 9>{229, 542, 680, 398, 1038, 616, 396, 556, 266}));
  auto missing = read_labels(labels_path.parent_path() / "no_such_labels.txt");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("no_such_labels.txt: file not found"), std::string::npos);
}

}  // namespace
}  // namespace gauss
