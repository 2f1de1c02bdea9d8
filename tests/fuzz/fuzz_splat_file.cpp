// Fuzz target: the splat-file dispatcher and its readers on arbitrary bytes. The name
// "fuzz.splat" makes the headerless .splat path reachable (any whole number of 32-byte
// records); SPZ, compressed PLY, SOG zips and 3DGS PLY are detected by content.
// Invariants checked beyond "no crash, no sanitizer report":
// - a rejection carries a message naming the input;
// - an accepted scene is complete and clean: report count = Gaussians, degree 0..3 and the same
//   in report and cloud, every value finite, unit quaternions, no SH beyond the degree, ids that
//   are the index unless the file carried its own, and it writes as a 3DGS PLY that reads back.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>

#include "fuzz_target.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/splat_file.h"

// A named namespace, not an anonymous one: fuzz_replay compiles the targets in unity
// batches, where two files' helpers of the same name would clash.
namespace fuzz_splat_file {

using gauss::finite3;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_splat_file invariant violated: %s\n", what);
  std::abort();
}

void check_scene(const gauss::SplatScene& s) {
  const gauss::GaussianCloud& c = s.cloud;
  if (s.report.count != c.gaussians.size()) fail("report count differs from the cloud");
  if (c.sh_degree < 0 || c.sh_degree > gauss::kMaxShDegree || s.report.sh_degree != c.sh_degree)
    fail("bad or inconsistent SH degree");
  const int rest = gauss::sh_rest_count(c.sh_degree);
  for (std::size_t i = 0; i < c.gaussians.size(); ++i) {
    const gauss::Gaussian& g = c.gaussians[i];
    if (!finite3(g.position) || !finite3(g.log_scale) || !finite3(g.sh_dc) || !std::isfinite(g.opacity_logit))
      fail("a non-finite value reached the cloud");
    const glm::vec4 q = g.rotation;
    const double n2 = double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3];
    if (!(std::abs(n2 - 1.0) <= 1e-5)) fail("a quaternion is not unit");
    for (int k = 0; k < gauss::kMaxShRest; ++k) {
      const glm::vec3& r = g.sh_rest[static_cast<std::size_t>(k)];
      if (!finite3(r)) fail("a non-finite SH coefficient");
      if (k >= rest && r != glm::vec3(0.0f)) fail("SH beyond the degree");
    }
    if (!s.report.has_gaussian_id && g.id != gauss::GaussianId{i}) fail("ids are not the index");
    if (!s.report.has_object_id && g.object != gauss::kNoObject) fail("an object label from nowhere");
  }
  auto ply = gauss::encode_gaussian_ply(c);
  if (!ply.ok()) fail("an accepted scene cannot be written as PLY");
  auto back = gauss::parse_gaussian_ply(*ply, "again.ply");
  if (!back.ok() || back->cloud.gaussians.size() != c.gaussians.size()) fail("the written PLY does not read back");
}

GAUSS_FUZZ_TARGET(splat_file) {
  const std::span<const std::uint8_t> bytes(data, size);
  auto scene = gauss::parse_splat_file(bytes, "fuzz.splat");
  if (!scene.ok()) {
    if (scene.message().rfind("fuzz.splat: ", 0) != 0) fail("rejection without the input's name");
    return 0;
  }
  check_scene(*scene);
  return 0;
}

}  // namespace fuzz_splat_file
