#pragma once
// A Gaussian's opacity from its stored logit (sigmoid), in double: what the format tests
// compare decoded opacities by.
#include <cmath>

namespace gauss::test {

inline double sigmoid(double logit) { return 1.0 / (1.0 + std::exp(-logit)); }

}  // namespace gauss::test
