// Rendering frame after frame must not grow the process. lavapipe (Mesa 22.3) inlines a
// uniform-buffer word that alone decides a branch or a loop bound into the shader and,
// when that shrinks the shader enough, compiles a fresh variant on every bind of the
// pipeline without freeing the last. splat_preprocess once guarded its highlight search
// with `view.frame.z > 0`: once a highlight was set after plain frames, every frame
// compiled the preprocess shader again (LLVM on the queue thread, 100-200 ms) and a
// querying client grew by about 4 MiB/s. This cycles through every state the renderer
// switches pipelines for (plain, highlight, edit tints, mesh) and bounds the growth of
// the resident set over the repeated cycles, which such a compile per frame exceeds
// several times over (it failed here at +58 MiB over 120 frames).
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/splat_math.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_frame_ring.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

// The resident set of this process in MiB (VmRSS of /proc/self/status), or -1.
double resident_mib() {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return -1.0;
}

class SplatSteadyMemory : public VkTest {};

TEST_F(SplatSteadyMemory, RepeatedHighlightTintAndMeshCyclesDoNotGrowTheProcess) {
  const auto scene = procedural_scene(1000, 1, 11);
  auto made = render::SplatRenderer::create(context(), {.capacity = 1000, .sh_degree = 1, .max_width = 64,
                                                        .max_height = 48, .frames_in_flight = 2});
  ASSERT_TRUE(made.ok()) << made.message();
  auto& r = **made;
  ASSERT_TRUE(r.write_slots(0, scene).ok());
  const std::vector<ObjectId> objects = {ObjectId{2}, ObjectId{5}};
  TriangleMesh wall;
  wall.positions = {{-3, -2, 9}, {3, -2, 9}, {0, 2, 9}};
  wall.colors.assign(3, {90, 90, 90});
  wall.indices = {0, 1, 2};

  // One cycle of 40 frames: plain, highlight, highlight + edit tints + a mesh chunk, mesh
  // gone and highlight cleared. The viewer moves and the display frame counts up, so the
  // view block changes every frame, as in a client.
  std::uint32_t frame_no = 0;
  auto cycle = [&] {
    for (std::uint32_t k = 0; k < 40; ++k, ++frame_no) {
      if (k == 10) {
        ASSERT_TRUE(r.set_highlight(objects).ok());
      }
      if (k == 20) {
        ASSERT_TRUE(r.set_mesh_chunk(1, wall).ok());
      }
      if (k >= 20 && k < 30) {
        const auto kind = static_cast<render::EditTintKind>(1 + k % 3);
        ASSERT_TRUE(r.set_edit_tints((k * 37) % 990, 10, {kind, 0}).ok());
      }
      if (k == 30) {
        r.remove_mesh_chunk(1);
        r.clear_highlight();
      }
      const double a = 0.02 * frame_no;
      const Camera cam = look_at_camera(64, 48, {0.3 * std::sin(a), 0.1 * std::cos(a), -0.5}, {0.0, 0.0, 5.0});
      auto s = r.render_frame(std::span<const Camera>(&cam, 1));
      ASSERT_TRUE(s.ok()) << s.message();
    }
  };
  ASSERT_NO_FATAL_FAILURE(cycle());  // every pipeline variant is made and compiled once
  ASSERT_TRUE(r.frames().wait_all().ok());
  const double before = resident_mib();
  ASSERT_GT(before, 0.0) << "no VmRSS in /proc/self/status";

  for (int c = 0; c < 4; ++c) ASSERT_NO_FATAL_FAILURE(cycle());
  ASSERT_TRUE(r.frames().wait_all().ok());
  const double after = resident_mib();
  // A frame allocates nothing that outlives it; the bound leaves room for allocator noise.
  EXPECT_LT(after - before, 12.0) << "resident set " << before << " -> " << after << " MiB over 160 frames";
}

}  // namespace
}  // namespace gauss::test
