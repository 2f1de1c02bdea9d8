// The derived marching-cubes table: structural properties every case must have.
#include <gtest/gtest.h>

#include "../../engine/src/tsdf/marching_cubes_table.h"

namespace gauss::tsdf {
namespace {

TEST(MarchingCubesTable, EveryCaseUsesOnlyCrossingEdgesAndClosesItsLoops) {
  const auto& table = marching_cubes_table();
  int max_triangles = 0;
  for (int mask = 0; mask < 256; ++mask) {
    const McCase& c = table[std::size_t(mask)];
    max_triangles = std::max(max_triangles, int(c.triangle_count));
    int crossing = 0;
    for (int e = 0; e < 12; ++e) {
      const int a = kEdgeCorners[std::size_t(e)][0], b = kEdgeCorners[std::size_t(e)][1];
      crossing += ((mask >> a) & 1) != ((mask >> b) & 1);
    }
    if (mask == 0 || mask == 255) {
      EXPECT_EQ(c.triangle_count, 0);
      continue;
    }
    EXPECT_GT(c.triangle_count, 0) << "mask " << mask;
    std::array<int, 12> used{};
    for (int t = 0; t < 3 * c.triangle_count; ++t) {
      const int e = c.edges[std::size_t(t)];
      const int a = kEdgeCorners[std::size_t(e)][0], b = kEdgeCorners[std::size_t(e)][1];
      EXPECT_NE((mask >> a) & 1, (mask >> b) & 1) << "mask " << mask << " uses non-crossing edge " << e;
      used[std::size_t(e)] = 1;
    }
    int used_count = 0;
    for (int u : used) used_count += u;
    EXPECT_EQ(used_count, crossing) << "mask " << mask << ": every crossing edge gets a vertex";
  }
  EXPECT_LE(max_triangles, 5);
}

TEST(MarchingCubesTable, ComplementCasesShareTheirFaceSegments) {
  // Inverting all signs flips which corners are inside. Faces without ambiguity give
  // the same segments, so the same edges are used, with the opposite winding.
  const auto& table = marching_cubes_table();
  auto edge_set = [&](int mask) {
    std::array<int, 12> used{};
    const McCase& c = table[std::size_t(mask)];
    for (int t = 0; t < 3 * c.triangle_count; ++t) used[c.edges[std::size_t(t)]] = 1;
    return used;
  };
  for (int mask = 1; mask < 255; ++mask) EXPECT_EQ(edge_set(mask), edge_set(255 - mask)) << mask;
}

}  // namespace
}  // namespace gauss::tsdf
