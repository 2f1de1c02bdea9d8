// xrLocateViews: both eyes from the scripted head pose of the frame displayed at
// displayTime, each ipd/2 from the head centre along the head's own x axis (left eye at
// -x), looking where the head looks, with the script's per-eye field of view.
#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {

XrResult xrLocateViews(XrSession session, const XrViewLocateInfo* locate_info, XrViewState* view_state,
                       uint32_t capacity, uint32_t* count, XrView* views) {
  const char* fn = "xrLocateViews";
  const auto lock = lock_runtime();
  const Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(locate_info, XR_TYPE_VIEW_LOCATE_INFO) || !typed(view_state, XR_TYPE_VIEW_STATE))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "viewLocateInfo must be an XrViewLocateInfo and viewState an XrViewState");
  if (locate_info->viewConfigurationType != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  if (locate_info->displayTime <= 0) return fail(XR_ERROR_TIME_INVALID, fn, "displayTime must be > 0");
  const Space* base = find(locate_info->space);
  if (base == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (base->session_id != to_id(session)) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "the space belongs to another session");
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const auto base_pose = space_in_stage(inst, *s, *base, locate_info->displayTime);
  const XrPosef head = inst.script.at(frame_at(inst, locate_info->displayTime)).head;
  const XrResult r = two_call(fn, capacity, count, views == nullptr, 2, [&](std::uint32_t eye) {
    if (views[eye].type != XR_TYPE_VIEW)
      return fail(XR_ERROR_VALIDATION_FAILURE, fn, "views[" + std::to_string(eye) + "] is not an XrView");
    const float half_ipd = inst.script.ipd * 0.5f;
    XrPosef eye_in_head = identity_pose();
    eye_in_head.position.x = eye == 0 ? -half_ipd : half_ipd;
    const XrPosef eye_in_stage = compose(head, eye_in_head);
    views[eye].pose = base_pose ? compose(inverse(*base_pose), eye_in_stage) : identity_pose();
    views[eye].fov = inst.script.fov[eye];
    return XR_SUCCESS;
  });
  if (XR_FAILED(r)) return r;
  view_state->viewStateFlags = base_pose ? XR_VIEW_STATE_ORIENTATION_VALID_BIT | XR_VIEW_STATE_POSITION_VALID_BIT |
                                               XR_VIEW_STATE_ORIENTATION_TRACKED_BIT | XR_VIEW_STATE_POSITION_TRACKED_BIT
                                         : 0;
  return with_health(*s, r);
}

}  // namespace gauss::xr_headless
