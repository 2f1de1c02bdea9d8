#include "gauss/engine/trainer_snapshot.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <glm/geometric.hpp>

#include "prng.h"

namespace gauss {

namespace {

// Sequential draws from one seed (SplitMix64 stream).
struct Draws {
  std::uint64_t state;
  std::uint64_t next() { return scene::mix64(state++); }
  float unit() { return scene::unit(next()); }
  float sym() { return scene::signed_unit(next()); }
  glm::vec3 sym3() { return {sym(), sym(), sym()}; }
  // A direction; the offset keeps it defined when the three draws are all zero.
  glm::vec3 dir() { return glm::normalize(sym3() + glm::vec3(1e-3f)); }
};

float largest_sigma(const Gaussian& g) {
  return std::exp(std::max(g.log_scale.x, std::max(g.log_scale.y, g.log_scale.z)));
}

}  // namespace

TrainerSnapshot make_trainer_snapshot(std::span<const Gaussian> previous, const TrainerSnapshotConfig& config,
                                      std::uint64_t seed) {
  Draws rng{scene::mix64(seed)};
  TrainerSnapshot out;
  out.gaussians.reserve(previous.size() + previous.size() / 16);
  for (const Gaussian& g : previous) {
    const float r = rng.unit();
    if (r < config.removed_fraction) {
      ++out.removed;
      continue;
    }
    Gaussian h = g;
    SnapshotFate fate = SnapshotFate::Unchanged;
    if (config.drift_sigmas > 0.0f) {
      h.position += config.drift_sigmas * largest_sigma(g) * rng.dir();
      h.sh_dc += 0.01f * rng.sym3();
    }
    if (r < config.removed_fraction + config.perturbed_fraction) {
      h.position += config.step_sigmas * largest_sigma(g) * rng.dir();
      h.log_scale += 0.05f * rng.sym3();
      h.sh_dc += 0.05f * rng.sym3();
      h.opacity_logit += 0.2f * rng.sym();
      fate = SnapshotFate::Perturbed;
    }
    out.gaussians.push_back(h);
    out.fate.push_back(fate);
    out.truth.push_back(g.id);
  }
  const auto n_new = static_cast<std::size_t>(std::llround(double(config.new_fraction) * double(previous.size())));
  for (std::size_t k = 0; k < n_new && !previous.empty(); ++k) {
    Gaussian h = previous[rng.next() % previous.size()];
    const float distance = 3.0f + 3.0f * rng.unit();  // drawn before the direction, on every compiler
    h.position += distance * largest_sigma(h) * rng.dir();
    h.sh_dc = 1.5f * rng.sym3();
    out.gaussians.push_back(h);
    out.fate.push_back(SnapshotFate::New);
    out.truth.push_back(GaussianId{0});
  }
  for (std::size_t i = out.gaussians.size(); i > 1; --i) {  // Fisher-Yates
    const std::size_t j = rng.next() % i;
    std::swap(out.gaussians[i - 1], out.gaussians[j]);
    std::swap(out.fate[i - 1], out.fate[j]);
    std::swap(out.truth[i - 1], out.truth[j]);
  }
  for (Gaussian& g : out.gaussians) g.id = GaussianId{0};
  return out;
}

}  // namespace gauss
