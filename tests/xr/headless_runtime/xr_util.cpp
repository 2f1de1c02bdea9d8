#include "xr_util.h"

#include <cmath>
#include <cstdio>

#include <glm/gtc/quaternion.hpp>
#include <openxr/openxr_reflection.h>

namespace gauss::xr_headless {
namespace {

#define GAUSS_XR_HEADLESS_CASE(name, value) \
  case name: return #name;

glm::dquat to_glm(const XrQuaternionf& q) { return glm::dquat(q.w, q.x, q.y, q.z); }
glm::dvec3 to_glm(const XrVector3f& v) { return glm::dvec3(v.x, v.y, v.z); }
XrQuaternionf to_xr(const glm::dquat& q) {
  return XrQuaternionf{static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z), static_cast<float>(q.w)};
}
XrVector3f to_xr(const glm::dvec3& v) {
  return XrVector3f{static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}

}  // namespace

const char* result_name(XrResult r) {
  switch (r) {
    XR_LIST_ENUM_XrResult(GAUSS_XR_HEADLESS_CASE)
    default: return nullptr;
  }
}

const char* structure_type_name(XrStructureType t) {
  switch (t) {
    XR_LIST_ENUM_XrStructureType(GAUSS_XR_HEADLESS_CASE)
    default: return nullptr;
  }
}

const char* session_state_name(XrSessionState s) {
  switch (s) {
    XR_LIST_ENUM_XrSessionState(GAUSS_XR_HEADLESS_CASE)
    default: return "XR_SESSION_STATE_?";
  }
}

const char* reference_space_name(XrReferenceSpaceType t) {
  switch (t) {
    XR_LIST_ENUM_XrReferenceSpaceType(GAUSS_XR_HEADLESS_CASE)
    default: return "XR_REFERENCE_SPACE_TYPE_?";
  }
}

void log_line(const std::string& message) { std::fprintf(stderr, "[gauss-xr-headless] %s\n", message.c_str()); }

XrResult fail(XrResult r, const char* function, const std::string& message) {
  const char* name = result_name(r);
  log_line(std::string(function) + ": " + message + " (" + (name ? name : std::to_string(r)) + ")");
  return r;
}

const void* find_in_chain(const void* next, XrStructureType type) {
  for (auto* p = static_cast<const XrBaseInStructure*>(next); p != nullptr; p = p->next)
    if (p->type == type) return p;
  return nullptr;
}

bool valid_pose(const XrPosef& p) {
  const auto& q = p.orientation;
  const double len2 = double(q.x) * q.x + double(q.y) * q.y + double(q.z) * q.z + double(q.w) * q.w;
  return std::isfinite(len2) && std::abs(len2 - 1.0) <= 2e-3 && std::isfinite(p.position.x) &&
         std::isfinite(p.position.y) && std::isfinite(p.position.z);
}

XrPosef identity_pose() {
  XrPosef p{};
  p.orientation.w = 1.0f;
  return p;
}

XrVector3f rotate(const XrQuaternionf& q, const XrVector3f& v) { return to_xr(to_glm(q) * to_glm(v)); }

XrPosef compose(const XrPosef& a, const XrPosef& b) {
  const glm::dquat qa = to_glm(a.orientation);
  XrPosef out;
  out.orientation = to_xr(qa * to_glm(b.orientation));  // both unit already: no renormalizing, so identities stay exact
  out.position = to_xr(to_glm(a.position) + qa * to_glm(b.position));
  return out;
}

XrPosef inverse(const XrPosef& p) {
  const glm::dquat qi = glm::conjugate(glm::normalize(to_glm(p.orientation)));
  XrPosef out;
  out.orientation = to_xr(qi);
  out.position = to_xr(-(qi * to_glm(p.position)));
  return out;
}

}  // namespace gauss::xr_headless
