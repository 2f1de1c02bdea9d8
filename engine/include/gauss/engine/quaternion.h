#pragma once
// Rotation quaternions are stored in a glm::vec4 in the PLY's rot_0..3 order:
// q[0] = w, q[1] = x, q[2] = y, q[3] = z. Trainers write unnormalised quaternions;
// every consumer uses the normalised one, so loaders normalise once, here.
#include <glm/vec4.hpp>

namespace gauss {

enum class QuaternionNormalization {
  Normalized,              // scaled to unit length (a no-op for unit input)
  ZeroReplacedByIdentity,  // zero length: no rotation is defined; identity is the documented choice
  NonFinite,               // NaN/Inf component: left untouched, the caller reports an error
};

// Normalises q in place, in double precision so lengths down to ~1e-38 still normalise.
QuaternionNormalization normalize_quaternion(glm::vec4& q);

}  // namespace gauss
