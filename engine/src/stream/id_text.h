#pragma once
// A Gaussian id as decimal text, for the stream's error messages.
#include <string>

#include "gauss/engine/ids.h"

namespace gauss {

inline std::string id_str(GaussianId id) { return std::to_string(to_underlying(id)); }

}  // namespace gauss
