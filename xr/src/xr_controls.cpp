#include "gauss/xr/xr_controls.h"

#include <cstring>
#include <string>
#include <vector>

#include "xr_check.h"

namespace gauss::xr {

using detail::xr_error;
using detail::xr_struct;

namespace {

Expected<XrAction> make_action(XrInstance instance, XrActionSet set, XrActionType type, const char* name,
                               const char* localized) {
  auto ci = xr_struct<XrActionCreateInfo>(XR_TYPE_ACTION_CREATE_INFO);
  ci.actionType = type;
  std::strncpy(ci.actionName, name, XR_MAX_ACTION_NAME_SIZE - 1);
  std::strncpy(ci.localizedActionName, localized, XR_MAX_LOCALIZED_ACTION_NAME_SIZE - 1);
  XrAction a = XR_NULL_HANDLE;
  if (const XrResult r = xrCreateAction(set, &ci, &a); XR_FAILED(r)) return xr_error(instance, "xrCreateAction", r);
  return a;
}

Expected<XrPath> path(XrInstance instance, const char* text) {
  XrPath p = XR_NULL_PATH;
  if (const XrResult r = xrStringToPath(instance, text, &p); XR_FAILED(r))
    return Error{std::string("OpenXR: xrStringToPath(") + text + ") failed (" + detail::result_text(instance, r) + ")"};
  return p;
}

}  // namespace

Expected<std::unique_ptr<Controls>> Controls::create(XrInstance instance, XrSession session, XrSpace space) {
  std::unique_ptr<Controls> c(new Controls());
  c->instance_ = instance;
  c->session_ = session;
  c->space_ = space;
  auto sci = xr_struct<XrActionSetCreateInfo>(XR_TYPE_ACTION_SET_CREATE_INFO);
  std::strncpy(sci.actionSetName, "gauss", XR_MAX_ACTION_SET_NAME_SIZE - 1);
  std::strncpy(sci.localizedActionSetName, "GaussAnything", XR_MAX_LOCALIZED_ACTION_SET_NAME_SIZE - 1);
  if (const XrResult r = xrCreateActionSet(instance, &sci, &c->set_); XR_FAILED(r))
    return xr_error(instance, "xrCreateActionSet", r);
  struct Def {
    XrAction* slot;
    XrActionType type;
    const char* name;
    const char* localized;
  };
  const Def defs[] = {{&c->aim_, XR_ACTION_TYPE_POSE_INPUT, "aim", "Point"},
                      {&c->trigger_, XR_ACTION_TYPE_FLOAT_INPUT, "select", "Select the object pointed at"},
                      {&c->next_, XR_ACTION_TYPE_BOOLEAN_INPUT, "next_class", "Next class query"},
                      {&c->clear_, XR_ACTION_TYPE_BOOLEAN_INPUT, "clear", "Clear the query"},
                      {&c->stick_, XR_ACTION_TYPE_VECTOR2F_INPUT, "rho", "Query share of the budget"}};
  for (const Def& d : defs) {
    auto a = make_action(instance, c->set_, d.type, d.name, d.localized);
    if (!a) return a.error();
    *d.slot = *a;
  }
  // Suggested bindings: a profile the runtime does not know is skipped (another may do).
  struct Binding {
    XrAction action;
    const char* path;
  };
  const std::pair<const char*, std::vector<Binding>> profiles[] = {
      {"/interaction_profiles/oculus/touch_controller",
       {{c->aim_, "/user/hand/right/input/aim/pose"},
        {c->trigger_, "/user/hand/right/input/trigger/value"},
        {c->next_, "/user/hand/right/input/a/click"},
        {c->clear_, "/user/hand/right/input/b/click"},
        {c->stick_, "/user/hand/right/input/thumbstick"}}},
      {"/interaction_profiles/khr/simple_controller",
       {{c->aim_, "/user/hand/right/input/aim/pose"},
        {c->trigger_, "/user/hand/right/input/select/click"},
        {c->clear_, "/user/hand/right/input/menu/click"}}}};
  int accepted = 0;
  for (const auto& [profile, bindings] : profiles) {
    auto pp = path(instance, profile);
    if (!pp) return pp.error();
    std::vector<XrActionSuggestedBinding> sb;
    for (const Binding& b : bindings) {
      auto bp = path(instance, b.path);
      if (!bp) return bp.error();
      sb.push_back({b.action, *bp});
    }
    auto s = xr_struct<XrInteractionProfileSuggestedBinding>(XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING);
    s.interactionProfile = *pp;
    s.countSuggestedBindings = static_cast<std::uint32_t>(sb.size());
    s.suggestedBindings = sb.data();
    if (XR_SUCCEEDED(xrSuggestInteractionProfileBindings(instance, &s))) ++accepted;
  }
  if (accepted == 0) return Error{"OpenXR: the runtime accepted no controller profile's bindings"};
  auto asci = xr_struct<XrActionSpaceCreateInfo>(XR_TYPE_ACTION_SPACE_CREATE_INFO);
  asci.action = c->aim_;
  asci.poseInActionSpace.orientation.w = 1.0f;
  if (const XrResult r = xrCreateActionSpace(session, &asci, &c->aim_space_); XR_FAILED(r))
    return xr_error(instance, "xrCreateActionSpace", r);
  auto attach = xr_struct<XrSessionActionSetsAttachInfo>(XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO);
  attach.countActionSets = 1;
  attach.actionSets = &c->set_;
  if (const XrResult r = xrAttachSessionActionSets(session, &attach); XR_FAILED(r))
    return xr_error(instance, "xrAttachSessionActionSets", r);
  return c;
}

Controls::~Controls() {
  if (aim_space_ != XR_NULL_HANDLE) xrDestroySpace(aim_space_);
  if (set_ != XR_NULL_HANDLE) xrDestroyActionSet(set_);  // destroys its actions too
}

Expected<ControllerInput> Controls::read(XrTime time) {
  ControllerInput in;
  auto active = XrActiveActionSet{set_, XR_NULL_PATH};
  auto sync = xr_struct<XrActionsSyncInfo>(XR_TYPE_ACTIONS_SYNC_INFO);
  sync.countActiveActionSets = 1;
  sync.activeActionSets = &active;
  const XrResult r = xrSyncActions(session_, &sync);
  if (r == XR_SESSION_NOT_FOCUSED) {
    last_trigger_ = 0.0f;
    last_stick_y_ = 0.0f;
    return in;
  }
  if (XR_FAILED(r)) return xr_error(instance_, "xrSyncActions", r);
  auto get = xr_struct<XrActionStateGetInfo>(XR_TYPE_ACTION_STATE_GET_INFO);
  get.action = trigger_;
  auto f = xr_struct<XrActionStateFloat>(XR_TYPE_ACTION_STATE_FLOAT);
  if (const XrResult e = xrGetActionStateFloat(session_, &get, &f); XR_FAILED(e))
    return xr_error(instance_, "xrGetActionStateFloat", e);
  in.trigger = f.isActive ? f.currentState : 0.0f;
  in.trigger_pulled = in.trigger > 0.5f && last_trigger_ <= 0.5f;
  last_trigger_ = in.trigger;
  for (auto [action, out] : {std::pair{next_, &in.next_class}, std::pair{clear_, &in.clear}}) {
    get.action = action;
    auto b = xr_struct<XrActionStateBoolean>(XR_TYPE_ACTION_STATE_BOOLEAN);
    if (const XrResult e = xrGetActionStateBoolean(session_, &get, &b); XR_FAILED(e))
      return xr_error(instance_, "xrGetActionStateBoolean", e);
    *out = b.isActive && b.changedSinceLastSync && b.currentState;
  }
  get.action = stick_;
  auto v = xr_struct<XrActionStateVector2f>(XR_TYPE_ACTION_STATE_VECTOR2F);
  if (const XrResult e = xrGetActionStateVector2f(session_, &get, &v); XR_FAILED(e))
    return xr_error(instance_, "xrGetActionStateVector2f", e);
  in.stick_y = v.isActive ? v.currentState.y : 0.0f;
  in.stick_steps = (in.stick_y > 0.5f && last_stick_y_ <= 0.5f) ? 1 : (in.stick_y < -0.5f && last_stick_y_ >= -0.5f) ? -1 : 0;
  last_stick_y_ = in.stick_y;
  auto loc = xr_struct<XrSpaceLocation>(XR_TYPE_SPACE_LOCATION);
  if (const XrResult e = xrLocateSpace(aim_space_, space_, time, &loc); XR_FAILED(e))
    return xr_error(instance_, "xrLocateSpace", e);
  const XrSpaceLocationFlags needed = XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT;
  in.aim_valid = (loc.locationFlags & needed) == needed;
  in.aim.orientation = glm::dquat(loc.pose.orientation.w, loc.pose.orientation.x, loc.pose.orientation.y,
                                  loc.pose.orientation.z);
  in.aim.position = glm::dvec3(loc.pose.position.x, loc.pose.position.y, loc.pose.position.z);
  return in;
}

void aim_ray(const XrPose& aim, const glm::dmat4& T_scene_space, glm::dvec3& origin, glm::dvec3& direction) {
  origin = glm::dvec3(T_scene_space * glm::dvec4(aim.position, 1.0));
  direction = glm::dmat3(T_scene_space) * (glm::normalize(aim.orientation) * glm::dvec3(0.0, 0.0, -1.0));
}

}  // namespace gauss::xr
