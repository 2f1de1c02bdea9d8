#include "marching_cubes_table.h"

#include <algorithm>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <vector>

namespace gauss::tsdf {
namespace {

glm::vec3 corner_pos(int c) { return {float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1)}; }

int edge_between(int a, int b) {
  for (int e = 0; e < 12; ++e) {
    const int c0 = kEdgeCorners[std::size_t(e)][0], c1 = kEdgeCorners[std::size_t(e)][1];
    if ((c0 == a && c1 == b) || (c0 == b && c1 == a)) return e;
  }
  return -1;
}

McCase build_case(int mask) {
  auto inside = [mask](int c) { return (mask >> c) & 1; };
  // The six faces, each as its four corners in cyclic order.
  static constexpr int kFaces[6][4] = {
      {0, 2, 6, 4}, {1, 3, 7, 5},  // x = 0, x = 1
      {0, 1, 5, 4}, {2, 3, 7, 6},  // y = 0, y = 1
      {0, 1, 3, 2}, {4, 5, 7, 6},  // z = 0, z = 1
  };
  // Undirected segments between crossing edges; each crossing edge lies on two faces,
  // so every edge id gets exactly two neighbours and the graph is a set of cycles.
  std::vector<std::vector<int>> adjacent(12);
  for (const auto& f : kFaces) {
    int crossings[4];
    int n = 0;
    for (int k = 0; k < 4; ++k) {
      const int a = f[k], b = f[(k + 1) % 4];
      if (inside(a) != inside(b)) crossings[n++] = k;  // side k of the face crosses
    }
    auto side_edge = [&](int k) { return edge_between(f[k], f[(k + 1) % 4]); };
    auto link = [&](int e0, int e1) {
      adjacent[std::size_t(e0)].push_back(e1);
      adjacent[std::size_t(e1)].push_back(e0);
    };
    if (n == 2) {
      link(side_edge(crossings[0]), side_edge(crossings[1]));
    } else if (n == 4) {
      // Ambiguous face: cut off each inside corner on its own. Corner f[k] touches
      // sides k-1 and k.
      for (int k = 0; k < 4; ++k)
        if (inside(f[k])) link(side_edge((k + 3) % 4), side_edge(k));
    }
  }
  McCase out;
  std::vector<bool> used(12, false);
  for (int start = 0; start < 12; ++start) {
    if (adjacent[std::size_t(start)].empty() || used[std::size_t(start)]) continue;
    std::vector<int> loop;
    int prev = -1, cur = start;
    while (!used[std::size_t(cur)]) {
      used[std::size_t(cur)] = true;
      loop.push_back(cur);
      const auto& nb = adjacent[std::size_t(cur)];
      const int next = nb[0] != prev ? nb[0] : nb[1];
      prev = cur;
      cur = next;
    }
    // Orientation: the polygon normal (edge midpoints) must point from the inside
    // corners of this loop toward its outside corners.
    glm::vec3 outward(0.0f), normal(0.0f);
    auto mid = [](int e) {
      return 0.5f * (corner_pos(kEdgeCorners[std::size_t(e)][0]) + corner_pos(kEdgeCorners[std::size_t(e)][1]));
    };
    for (int e : loop) {
      const int c0 = kEdgeCorners[std::size_t(e)][0], c1 = kEdgeCorners[std::size_t(e)][1];
      outward += inside(c0) ? corner_pos(c1) - corner_pos(c0) : corner_pos(c0) - corner_pos(c1);
    }
    for (std::size_t i = 0; i < loop.size(); ++i)
      normal += glm::cross(mid(loop[i]), mid(loop[(i + 1) % loop.size()]));
    if (glm::dot(normal, outward) < 0.0f) std::reverse(loop.begin(), loop.end());
    for (std::size_t i = 1; i + 1 < loop.size(); ++i) {
      const std::size_t t = out.triangle_count++;
      out.edges[3 * t + 0] = std::uint8_t(loop[0]);
      out.edges[3 * t + 1] = std::uint8_t(loop[i]);
      out.edges[3 * t + 2] = std::uint8_t(loop[i + 1]);
    }
  }
  return out;
}

}  // namespace

const std::array<McCase, 256>& marching_cubes_table() {
  static const std::array<McCase, 256> table = [] {
    std::array<McCase, 256> t{};
    for (int m = 0; m < 256; ++m) t[std::size_t(m)] = build_case(m);
    return t;
  }();
  return table;
}

}  // namespace gauss::tsdf
