#pragma once
// Small helpers every entry point uses: enum names, the error report, struct type checks,
// the two-call idiom, and pose arithmetic.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "xr_headers.h"

namespace gauss::xr_headless {

// "XR_ERROR_VALIDATION_FAILURE" etc., or nullptr for a value the headers do not name.
const char* result_name(XrResult r);
const char* structure_type_name(XrStructureType t);
const char* session_state_name(XrSessionState s);
const char* reference_space_name(XrReferenceSpaceType t);

// Prints "[gauss-xr-headless] <function>: <message> (<result name>)" to stderr and
// returns `r`, so an app developer sees why a call failed, not only the code.
XrResult fail(XrResult r, const char* function, const std::string& message);
void log_line(const std::string& message);

// The input struct has the expected type tag (a null pointer does not).
template <class T>
bool typed(const T* p, XrStructureType type) {
  return p != nullptr && p->type == type;
}

// Copies `s` into a fixed char array, cut to fit and always NUL-terminated.
template <std::size_t N>
void copy_string(char (&out)[N], std::string_view s) {
  const std::size_t n = std::min(s.size(), N - 1);
  std::memcpy(out, s.data(), n);
  out[n] = '\0';
}

// The first struct of `type` in a next chain, or nullptr.
const void* find_in_chain(const void* next, XrStructureType type);

// The spec's two-call idiom: `*count_out` gets `count`; with capacity 0 that is all;
// otherwise `items` must hold `count` (else XR_ERROR_SIZE_INSUFFICIENT) and `fill(i)`
// writes item i (and may fail, e.g. on a wrong struct type).
template <class Fill>
XrResult two_call(const char* function, std::uint32_t capacity, std::uint32_t* count_out, bool items_null,
                  std::uint32_t count, Fill fill) {
  if (count_out == nullptr) return fail(XR_ERROR_VALIDATION_FAILURE, function, "the count output pointer is null");
  *count_out = count;
  if (capacity == 0) return XR_SUCCESS;
  if (items_null) return fail(XR_ERROR_VALIDATION_FAILURE, function, "capacity > 0 but the array pointer is null");
  if (capacity < count) return XR_ERROR_SIZE_INSUFFICIENT;
  for (std::uint32_t i = 0; i < count; ++i)
    if (const XrResult r = fill(i); XR_FAILED(r)) return r;
  return XR_SUCCESS;
}

// Poses: unit quaternion check (within 1e-3, as runtimes commonly allow), composition
// (a * b: b expressed in a's frame, mapped to a's parent) and inverse.
bool valid_pose(const XrPosef& p);
XrPosef identity_pose();
XrPosef compose(const XrPosef& a, const XrPosef& b);
XrPosef inverse(const XrPosef& p);
XrVector3f rotate(const XrQuaternionf& q, const XrVector3f& v);

}  // namespace gauss::xr_headless
