#pragma once
// Small helpers for OpenXR calls: typed structs and readable results.
#include <string>

#include <openxr/openxr.h>

#include "gauss/engine/result.h"

namespace gauss::xr::detail {

// OpenXR structs start with a type tag; everything else zero.
template <class T>
T xr_struct(XrStructureType type) {
  T v{};
  v.type = type;
  return v;
}

// "XR_ERROR_SESSION_LOST" (or the number when the instance cannot name it).
inline std::string result_text(XrInstance instance, XrResult r) {
  char buf[XR_MAX_RESULT_STRING_SIZE] = {};
  if (instance != XR_NULL_HANDLE && xrResultToString(instance, r, buf) == XR_SUCCESS) return buf;
  return "XrResult " + std::to_string(int(r));
}

// An error naming the call and its result.
inline Error xr_error(XrInstance instance, const char* call, XrResult r) {
  return Error{std::string("OpenXR: ") + call + " failed (" + result_text(instance, r) + ")"};
}

}  // namespace gauss::xr::detail
