#pragma once
// The core scene primitive, stored exactly as 3DGS trainers write it (log-scales,
// opacity logit, SH coefficients), so reading and writing a PLY is lossless.
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "gauss/engine/ids.h"

namespace gauss {

inline constexpr int kMaxShDegree = 3;
// Non-DC SH coefficients per colour channel for degree d: (d+1)^2 - 1.
// Degree-0 real SH basis constant: a Gaussian's base colour is 0.5 + kShC0 * sh_dc.
inline constexpr double kShC0 = 0.28209479177387814;

constexpr int sh_rest_count(int degree) { return (degree + 1) * (degree + 1) - 1; }
inline constexpr int kMaxShRest = sh_rest_count(kMaxShDegree);  // 15

struct Gaussian {
  glm::vec3 position{0.0f};
  glm::vec3 log_scale{0.0f};               // scale = exp(log_scale), metres
  glm::vec4 rotation{1.0f, 0.0f, 0.0f, 0.0f};  // rotation[0..3] = w, x, y, z (PLY rot_0..3); unit after load
  float opacity_logit{0.0f};               // opacity = sigmoid(opacity_logit)
  glm::vec3 sh_dc{0.0f};                   // degree-0 SH coefficient per channel (f_dc_0..2)
  // Higher SH coefficients, coefficient-major: sh_rest[k] is the RGB triple of
  // coefficient k+1. (The PLY stores f_rest channel-major; I/O transposes.)
  // Entries beyond the scene's degree are zero.
  std::array<glm::vec3, kMaxShRest> sh_rest{};
  GaussianId id{0};                        // persistent id
  ObjectId object{kNoObject};              // semantic instance, kNoObject when unlabelled
  std::uint32_t support{0};                // observation count (reconstruction support)
  bool carrier{false};  // upstream semantic carrier: never counts as appearance residency
};

// Whether every component of a 3-vector (float or double) is finite.
template <typename T, glm::qualifier Q>
bool finite3(const glm::vec<3, T, Q>& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Field-wise equality of everything but the id: "the same value" (a bit-identical modify is
// no change). Not memcmp: Gaussian has padding.
inline bool same_value(const Gaussian& a, const Gaussian& b) {
  return a.position == b.position && a.log_scale == b.log_scale && a.rotation == b.rotation &&
         a.opacity_logit == b.opacity_logit && a.sh_dc == b.sh_dc && a.sh_rest == b.sh_rest &&
         a.object == b.object && a.support == b.support && a.carrier == b.carrier;
}

// A set of Gaussians with the SH degree they actually carry.
struct GaussianCloud {
  int sh_degree{0};
  std::vector<Gaussian> gaussians;
};

}  // namespace gauss
