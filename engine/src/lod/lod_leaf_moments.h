#pragma once
// leaf_moments over a leaf's fields where they lie (the hierarchy's leaf slots, a scene's
// Gaussian), without assembling a Gaussian first: at a million leaves, copying each into a
// 256-byte Gaussian to merge it cost more than the merge. leaf_moments is this function, so
// the two agree bit for bit.
#include <cstdint>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/lod_merge.h"

namespace gauss::lod_detail {

struct LeafFieldRefs {
  const glm::vec3& position;
  const glm::vec3& log_scale;
  const glm::vec4& rotation;
  float opacity_logit;
  const glm::vec3& sh_dc;
  const glm::vec3* rest;  // rest_count triples
  ObjectId object;
  std::uint32_t support;
};

// As leaf_moments, with rest_count = sh_rest_count of the degree. With `out` null only the
// status is computed (what the hierarchy's full build asks of every input Gaussian); otherwise
// `out` and `rest_out` (rest_count triples) are written when Usable.
LodLeafStatus leaf_moments_of(const LeafFieldRefs& leaf, int rest_count, const LodMergeConfig& config,
                              LodMoments* out, glm::dvec3* rest_out);

// Whether `g` may enter a merge (leaf_moments' status) without computing its moments: what an
// update asks of every Gaussian it is given before storing it as a leaf.
inline LodLeafStatus leaf_status(const Gaussian& g, int rest_count, const LodMergeConfig& config) {
  const LeafFieldRefs fields{g.position, g.log_scale, g.rotation, g.opacity_logit,
                             g.sh_dc,    g.sh_rest.data(), g.object, g.support};
  return leaf_moments_of(fields, rest_count, config, nullptr, nullptr);
}

}  // namespace gauss::lod_detail
