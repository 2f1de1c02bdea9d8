#include "gauss/engine/quaternion.h"

#include <cmath>

namespace gauss {

QuaternionNormalization normalize_quaternion(glm::vec4& q) {
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w))
    return QuaternionNormalization::NonFinite;
  // Norm in double: a 1e-20-length quaternion squares to 1e-40, below float's normal range.
  const double n = std::sqrt(double(q.x) * q.x + double(q.y) * q.y + double(q.z) * q.z + double(q.w) * q.w);
  if (!(n > 0.0)) {
    q = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
    return QuaternionNormalization::ZeroReplacedByIdentity;
  }
  q = glm::vec4(float(q.x / n), float(q.y / n), float(q.z / n), float(q.w / n));  // order kept: (w, x, y, z)
  return QuaternionNormalization::Normalized;
}

}  // namespace gauss
