#include "gauss/client/ray_pick.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "gauss/engine/gaussian.h"

namespace gauss::client {

namespace {

constexpr double kMaxSigmas = 2.0;
constexpr double kMinOpacity = 0.5;
constexpr double kMinScale = 1e-4;

}  // namespace

std::optional<RayHit> pick(const SlotTable& slots, const glm::dvec3& origin, const glm::dvec3& direction) {
  if (!finite3(origin) || !finite3(direction) || glm::length(direction) <= 0.0) return std::nullopt;
  const glm::dvec3 dir = glm::normalize(direction);
  std::optional<RayHit> best;
  for (std::uint32_t k = 0; k < slots.capacity(); ++k) {
    GaussianId id{0};
    if (!slots.occupant(SlotIndex{k}, id)) continue;
    const Gaussian& g = slots.records()[k];
    if (1.0 / (1.0 + std::exp(-double(g.opacity_logit))) < kMinOpacity) continue;
    // Into the Gaussian's frame, scaled to unit sigmas: the ray's closest approach to the
    // centre there is its Mahalanobis distance.
    const glm::dquat q = glm::normalize(glm::dquat(g.rotation[0], g.rotation[1], g.rotation[2], g.rotation[3]));
    const glm::dquat inv = glm::conjugate(q);
    glm::dvec3 scale;
    for (int a = 0; a < 3; ++a) scale[a] = std::max(std::exp(double(g.log_scale[a])), kMinScale);
    if (!finite3(scale)) continue;
    const glm::dvec3 o = (inv * (origin - glm::dvec3(g.position))) / scale;
    const glm::dvec3 d = (inv * dir) / scale;
    const double dd = glm::dot(d, d);
    const double t_local = -glm::dot(o, d) / dd;  // in units of the world ray's length (dir is unit)
    if (t_local <= 0.0) continue;                 // behind the controller
    const glm::dvec3 closest = o + t_local * d;
    if (glm::dot(closest, closest) > kMaxSigmas * kMaxSigmas) continue;
    if (!best || t_local < best->distance) best = RayHit{g.object, t_local, k};
  }
  return best;
}

}  // namespace gauss::client
