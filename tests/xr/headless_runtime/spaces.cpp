// Spaces. Everything the script moves is given in STAGE space, the floor-level origin at
// the centre of the stage rectangle. LOCAL coincides with STAGE here (a real runtime puts
// it at the initial head position; apps must not rely on either); VIEW follows the head.
// An action space follows its pose action's controller and is untracked while that action
// is inactive (unbound, not synced, or the session not focused).
#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

constexpr XrReferenceSpaceType kReferenceSpaces[] = {XR_REFERENCE_SPACE_TYPE_VIEW, XR_REFERENCE_SPACE_TYPE_LOCAL,
                                                     XR_REFERENCE_SPACE_TYPE_STAGE};

bool offered(XrReferenceSpaceType t) {
  return std::find(std::begin(kReferenceSpaces), std::end(kReferenceSpaces), t) != std::end(kReferenceSpaces);
}

}  // namespace

std::optional<XrPosef> space_in_stage(const Instance& instance, const Session& session, const Space& space, XrTime time) {
  const std::uint64_t frame = frame_at(instance, time);
  if (space.is_action) {
    const auto pose = action_pose(instance, session, space.action_id, space.slot, frame);
    if (!pose) return std::nullopt;
    return compose(*pose, space.offset);
  }
  if (space.reference == XR_REFERENCE_SPACE_TYPE_VIEW) return compose(instance.script.at(frame).head, space.offset);
  return space.offset;  // LOCAL and STAGE: the stage origin
}

XrResult xrEnumerateReferenceSpaces(XrSession session, uint32_t capacity, uint32_t* count, XrReferenceSpaceType* spaces) {
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  const XrResult r = two_call("xrEnumerateReferenceSpaces", capacity, count, spaces == nullptr,
                              static_cast<std::uint32_t>(std::size(kReferenceSpaces)), [&](std::uint32_t i) {
                                spaces[i] = kReferenceSpaces[i];
                                return XR_SUCCESS;
                              });
  return XR_FAILED(r) ? r : with_health(*s, r);
}

XrResult xrCreateReferenceSpace(XrSession session, const XrReferenceSpaceCreateInfo* create_info, XrSpace* space) {
  const char* fn = "xrCreateReferenceSpace";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(create_info, XR_TYPE_REFERENCE_SPACE_CREATE_INFO) || space == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrReferenceSpaceCreateInfo and space non-null");
  if (!offered(create_info->referenceSpaceType))
    return fail(XR_ERROR_REFERENCE_SPACE_UNSUPPORTED, fn, "only VIEW, LOCAL and STAGE are offered");
  if (!valid_pose(create_info->poseInReferenceSpace))
    return fail(XR_ERROR_POSE_INVALID, fn, "poseInReferenceSpace has a non-unit orientation");
  auto sp = std::make_unique<Space>();
  sp->session_id = to_id(session);
  sp->reference = create_info->referenceSpaceType;
  sp->offset = create_info->poseInReferenceSpace;
  *space = to_handle<XrSpace>(runtime().spaces.insert(std::move(sp)));
  return with_health(*s, XR_SUCCESS);
}

XrResult xrGetReferenceSpaceBoundsRect(XrSession session, XrReferenceSpaceType type, XrExtent2Df* bounds) {
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (bounds == nullptr) return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetReferenceSpaceBoundsRect", "bounds is null");
  if (!offered(type)) return XR_ERROR_REFERENCE_SPACE_UNSUPPORTED;
  if (type != XR_REFERENCE_SPACE_TYPE_STAGE) {
    *bounds = XrExtent2Df{0.0f, 0.0f};
    return with_health(*s, XR_SPACE_BOUNDS_UNAVAILABLE);
  }
  *bounds = runtime().instances.find(s->instance_id)->script.stage;
  return with_health(*s, XR_SUCCESS);
}

XrResult xrCreateActionSpace(XrSession session, const XrActionSpaceCreateInfo* create_info, XrSpace* space) {
  const char* fn = "xrCreateActionSpace";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(create_info, XR_TYPE_ACTION_SPACE_CREATE_INFO) || space == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrActionSpaceCreateInfo and space non-null");
  const Action* action = find(create_info->action);
  if (action == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (action->instance_id != s->instance_id) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "the action belongs to another instance");
  if (action->type != XR_ACTION_TYPE_POSE_INPUT) return fail(XR_ERROR_ACTION_TYPE_MISMATCH, fn, "the action is not a pose action");
  if (!valid_pose(create_info->poseInActionSpace))
    return fail(XR_ERROR_POSE_INVALID, fn, "poseInActionSpace has a non-unit orientation");
  int slot = kSlotAny;
  if (create_info->subactionPath != XR_NULL_PATH) {
    const auto& subs = action->subaction_paths;
    if (std::find(subs.begin(), subs.end(), create_info->subactionPath) == subs.end())
      return fail(XR_ERROR_PATH_UNSUPPORTED, fn, "subactionPath is not one of the action's subaction paths");
    const Instance& inst = *runtime().instances.find(s->instance_id);
    slot = *inst.paths.lookup(create_info->subactionPath) == kLeftHandPath ? kSlotLeft : kSlotRight;
  }
  auto sp = std::make_unique<Space>();
  sp->session_id = to_id(session);
  sp->is_action = true;
  sp->action_id = to_id(create_info->action);
  sp->slot = slot;
  sp->offset = create_info->poseInActionSpace;
  *space = to_handle<XrSpace>(runtime().spaces.insert(std::move(sp)));
  return with_health(*s, XR_SUCCESS);
}

XrResult xrLocateSpace(XrSpace space, XrSpace base_space, XrTime time, XrSpaceLocation* location) {
  const char* fn = "xrLocateSpace";
  const auto lock = lock_runtime();
  const Space* sp = find(space);
  const Space* base = find(base_space);
  if (sp == nullptr || base == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (sp->session_id != base->session_id) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "the spaces belong to different sessions");
  const Session* s = runtime().sessions.find(sp->session_id);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(location, XR_TYPE_SPACE_LOCATION)) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "location must be an XrSpaceLocation");
  if (time <= 0) return fail(XR_ERROR_TIME_INVALID, fn, "time must be > 0");
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const auto a = space_in_stage(inst, *s, *sp, time);
  const auto b = space_in_stage(inst, *s, *base, time);
  // Velocities are not simulated: an XrSpaceVelocity in the chain reports none as valid.
  if (auto* velocity = static_cast<XrSpaceVelocity*>(const_cast<void*>(find_in_chain(location->next, XR_TYPE_SPACE_VELOCITY))))
    velocity->velocityFlags = 0;
  if (!a || !b) {
    location->locationFlags = 0;
    location->pose = identity_pose();
    return with_health(*s, XR_SUCCESS);
  }
  location->pose = compose(inverse(*b), *a);
  location->locationFlags = XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT |
                            XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
  return with_health(*s, XR_SUCCESS);
}

XrResult xrDestroySpace(XrSpace space) {
  const auto lock = lock_runtime();
  if (find(space) == nullptr) return XR_ERROR_HANDLE_INVALID;
  runtime().spaces.remove(to_id(space));
  return XR_SUCCESS;
}

}  // namespace gauss::xr_headless
