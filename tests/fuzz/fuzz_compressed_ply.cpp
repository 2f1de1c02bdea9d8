// Fuzz target: the quantised splat readers on arbitrary bytes: PlayCanvas compressed PLY and
// SOG (a zip of meta.json + WebP images). Invariants checked beyond "no crash, no sanitizer
// report":
// - a rejection always carries a message naming the input;
// - an accepted scene is whole and clean: report count and degree agree with the cloud, every
//   float is finite, quaternions are unit, ids are the index, no object labels, SH beyond the
//   degree is zero.
// The seed corpus (corpus/compressed_ply/) is written by the disabled test
// FuzzSeeds.DISABLED_WriteFuzzSeeds in tests/engine/test_splat_compressed_sog.cpp, plus
// fuzzer findings kept as regressions (colour_bound_overflow.ply: a colour bound whose f_dc
// overflowed a float).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>

#include "fuzz_target.h"
#include "gauss/engine/splat_file.h"

// A named namespace, not an anonymous one: fuzz_replay compiles the targets in unity
// batches, where two files' helpers of the same name would clash.
namespace fuzz_compressed_ply {

using gauss::finite3;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_compressed_ply invariant violated: %s\n", what);
  std::abort();
}

void check(const gauss::Expected<gauss::SplatScene>& scene, const std::string& name) {
  if (!scene.ok()) {
    if (scene.message().rfind(name + ": ", 0) != 0) fail("rejection without the input's name");
    return;
  }
  const gauss::GaussianCloud& c = scene->cloud;
  if (scene->report.count != c.gaussians.size() || scene->report.sh_degree != c.sh_degree) fail("report disagrees");
  if (c.sh_degree < 0 || c.sh_degree > gauss::kMaxShDegree) fail("impossible SH degree");
  const int coefs = gauss::sh_rest_count(c.sh_degree);
  for (std::size_t i = 0; i < c.gaussians.size(); ++i) {
    const gauss::Gaussian& g = c.gaussians[i];
    if (!finite3(g.position) || !finite3(g.log_scale) || !finite3(g.sh_dc) || !std::isfinite(g.opacity_logit))
      fail("a non-finite value reached the cloud");
    double n2 = 0;
    for (int k = 0; k < 4; ++k) {
      if (!std::isfinite(g.rotation[k])) fail("non-finite quaternion");
      n2 += double(g.rotation[k]) * g.rotation[k];
    }
    if (std::abs(std::sqrt(n2) - 1.0) > 1e-5) fail("quaternion not unit");
    for (int k = 0; k < gauss::kMaxShRest; ++k) {
      const glm::vec3& r = g.sh_rest[static_cast<std::size_t>(k)];
      if (!finite3(r)) fail("non-finite SH coefficient");
      if (k >= coefs && (r.x != 0.0f || r.y != 0.0f || r.z != 0.0f)) fail("SH beyond the degree");
    }
    if (g.id != gauss::GaussianId{i} || g.object != gauss::kNoObject) fail("ids are not the index");
  }
}

GAUSS_FUZZ_TARGET(compressed_ply) {
  const std::span<const std::uint8_t> bytes(data, size);
  check(gauss::parse_compressed_ply(bytes, "fuzz.ply"), "fuzz.ply");
  check(gauss::parse_sog_zip(bytes, "fuzz.sog"), "fuzz.sog");
  return 0;
}

}  // namespace fuzz_compressed_ply
