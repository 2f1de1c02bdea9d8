#pragma once
// Decode steps shared by the quantised splat readers (compressed PLY, SOG). Private to engine/.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/kept_file_indices.h"
#include "gauss/engine/ply_gaussian.h"  // kQuaternionUnitTolerance
#include "gauss/engine/quaternion.h"
#include "gauss/engine/splat_file.h"

namespace gauss::io {


// An 8-bit alpha of 0 or 255 has no finite logit. Decoded alphas are clamped to
// [0.5/255, 1 - 0.5/255], i.e. logits within +-ln(509) = +-6.2324: the clamped value is still
// within half a step of every source alpha that quantises to 0 or 255, so sigmoid(logit) stays
// within the format's alpha error. Compare opacities, not logits: the logit error near 0 and 1
// is unbounded by construction.
inline constexpr double kMinDecodedAlpha = 0.5 / 255.0;

inline float alpha_to_logit(double alpha) {
  const double a = std::clamp(alpha, kMinDecodedAlpha, 1.0 - kMinDecodedAlpha);
  return static_cast<float>(std::log(a / (1.0 - a)));
}

// Rebuilds the component the "smallest three" encodings leave out: the largest by magnitude,
// stored non-negative, so that the quaternion has unit length. `rest` holds the other three in
// rot_0..rot_3 order; `largest` is its index 0..3 (0 = w). Quantisation can make the three
// stored components' squares sum past 1: the rebuilt one is then 0 (never NaN) and the
// quaternion is renormalised later.
inline glm::vec4 rebuild_quaternion(int largest, double a, double b, double c) {
  const double m = std::sqrt(std::max(0.0, 1.0 - (a * a + b * b + c * c)));
  const double rest[3] = {a, b, c};
  double q[4];
  for (int k = 0, r = 0; k < 4; ++k) q[k] = k == largest ? m : rest[r++];
  return glm::vec4(static_cast<float>(q[0]), static_cast<float>(q[1]), static_cast<float>(q[2]),
                   static_cast<float>(q[3]));
}

// The last step of every quantised reader: ids are the file index, no object labels, and each
// quaternion that is not unit within kQuaternionUnitTolerance is normalised and counted (as
// the PLY reader does, so loading twice changes nothing).
inline void finish_quantized_scene(SplatScene& scene) {
  SplatFileReport& report = scene.report;
  std::vector<Gaussian>& gs = scene.cloud.gaussians;
  KeptFileIndices file_index(report.dropped);
  for (std::size_t i = 0; i < gs.size(); ++i) {
    Gaussian& g = gs[i];
    g.id = GaussianId{file_index.next()};
    g.object = kNoObject;
    const glm::vec4 q = g.rotation;
    const double n2 = double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3];
    if (std::abs(std::sqrt(n2) - 1.0) <= kQuaternionUnitTolerance) continue;
    if (normalize_quaternion(g.rotation) == QuaternionNormalization::ZeroReplacedByIdentity)
      ++report.zero_quaternions;
    else
      ++report.renormalized_quaternions;
  }
  report.count = gs.size();
  report.sh_degree = scene.cloud.sh_degree;
}

}  // namespace gauss::io
