// Action state: xrSyncActions reads the scripted controllers of the frame last waited on
// through the attached bindings, and the xrGetActionState* calls report that snapshot.
//
// Rules (the spec's, where it has one):
//  - an action is active for a subaction slot when the session is FOCUSED, its set was in
//    the sync's active list for that hand, and it is bound to an input of that hand;
//  - several bindings combine: booleans OR, floats the largest magnitude, vectors the
//    longest; float inputs read through a boolean action are pressed above 0.5;
//  - changedSinceLastSync is true when the value differs from the previous sync and the
//    action was active both times; lastChangeTime is the display time of the frame whose
//    state first showed the current value (or became active).
#include <cmath>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

bool slot_has_hand(int slot, Hand hand) {
  return slot == kSlotAny || (slot == kSlotLeft) == (hand == Hand::kLeft);
}

int hand_slot(Hand hand) { return hand == Hand::kLeft ? kSlotLeft : kSlotRight; }

// The frame whose state xrSyncActions reads: the one last waited on.
std::uint64_t sync_frame(const Session& s) { return s.frames_waited == 0 ? 0 : s.frames_waited - 1; }

// The bindings of `action_id` usable in `slot` right now (its set active for that hand).
std::vector<const SuggestedBinding*> live_bindings(const Session& s, const Action& action, std::uint64_t action_id, int slot) {
  std::vector<const SuggestedBinding*> out;
  auto sets = s.active_sets.find(action.set_id);
  auto it = s.bindings.find(action_id);
  if (sets == s.active_sets.end() || it == s.bindings.end()) return out;
  for (const SuggestedBinding& b : it->second)
    if (slot_has_hand(slot, b.target.hand) && sets->second[hand_slot(b.target.hand)]) out.push_back(&b);
  return out;
}

ActionSlotState read_slot(const Session& s, const Action& action, std::uint64_t action_id, int slot, const TrackedState& now) {
  ActionSlotState st;
  const auto bindings = live_bindings(s, action, action_id, slot);
  st.active = s.state == XR_SESSION_STATE_FOCUSED && !bindings.empty();
  if (!st.active) return st;
  for (const SuggestedBinding* b : bindings) {
    const HandState& hand = b->target.hand == Hand::kLeft ? now.left : now.right;
    const InputValue v = read_input(hand, b->target.input);
    st.boolean = st.boolean || v.boolean;
    if (std::abs(v.value) > std::abs(st.value)) st.value = v.value;
    if (std::hypot(v.vector.x, v.vector.y) > std::hypot(st.vector.x, st.vector.y)) st.vector = v.vector;
  }
  return st;
}

bool same_value(const Action& action, const ActionSlotState& a, const ActionSlotState& b) {
  switch (action.type) {
    case XR_ACTION_TYPE_BOOLEAN_INPUT: return a.boolean == b.boolean;
    case XR_ACTION_TYPE_FLOAT_INPUT: return a.value == b.value;
    case XR_ACTION_TYPE_VECTOR2F_INPUT: return a.vector.x == b.vector.x && a.vector.y == b.vector.y;
    default: return true;  // poses and outputs have no value to change
  }
}

// Checks common to the xrGetActionState* calls; on success `*out` is the slot's state.
XrResult get_state(const char* fn, XrSession session, const XrActionStateGetInfo* info, XrActionType type,
                   const ActionSlotState** out, Session** session_out) {
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(info, XR_TYPE_ACTION_STATE_GET_INFO)) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "getInfo must be an XrActionStateGetInfo");
  const Action* action = find(info->action);
  if (action == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (action->type != type) return fail(XR_ERROR_ACTION_TYPE_MISMATCH, fn, "action " + action->name + " has another type");
  if (!attached_to(*s, *action)) return fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, fn, "the action's set is not attached");
  const int slot = subaction_slot(*runtime().instances.find(s->instance_id), *action, info->subactionPath);
  if (slot < 0) return fail(XR_ERROR_PATH_UNSUPPORTED, fn, "subactionPath is not one of the action's subaction paths");
  *out = &s->action_states.at(to_id(info->action))[slot];
  *session_out = s;
  return XR_SUCCESS;
}

}  // namespace

std::optional<XrPosef> action_pose(const Instance& instance, const Session& session, std::uint64_t action_id, int slot,
                                   std::uint64_t frame) {
  const Action* action = runtime().actions.find(action_id);
  if (action == nullptr || !attached_to(session, *action)) return std::nullopt;
  auto states = session.action_states.find(action_id);
  if (states == session.action_states.end() || !states->second[slot].active) return std::nullopt;
  const auto bindings = live_bindings(session, *action, action_id, slot);
  if (bindings.empty()) return std::nullopt;
  // With several bound poses the first suggested one wins (the spec leaves it to the runtime).
  const TrackedState& state = instance.script.at(frame);
  const SuggestedBinding& b = *bindings.front();
  return read_pose(b.target.hand == Hand::kLeft ? state.left : state.right, b.target.input);
}

XrResult xrSyncActions(XrSession session, const XrActionsSyncInfo* sync_info) {
  const char* fn = "xrSyncActions";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(sync_info, XR_TYPE_ACTIONS_SYNC_INFO) ||
      (sync_info->countActiveActionSets > 0 && sync_info->activeActionSets == nullptr))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "syncInfo must be an XrActionsSyncInfo (with its active sets)");
  const Instance& inst = *runtime().instances.find(s->instance_id);
  std::map<std::uint64_t, std::array<bool, 3>> active;
  for (std::uint32_t i = 0; i < sync_info->countActiveActionSets; ++i) {
    const XrActiveActionSet& a = sync_info->activeActionSets[i];
    const ActionSet* set = find(a.actionSet);
    if (set == nullptr) return XR_ERROR_HANDLE_INVALID;
    const std::uint64_t set_id = to_id(a.actionSet);
    if (std::find(s->attached_sets.begin(), s->attached_sets.end(), set_id) == s->attached_sets.end())
      return fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, fn, "action set " + set->name + " is not attached to this session");
    auto& hands = active[set_id];
    if (a.subactionPath == XR_NULL_PATH) {
      hands = {true, true, true};
      continue;
    }
    const std::string* p = inst.paths.lookup(a.subactionPath);
    if (p == nullptr || (*p != kLeftHandPath && *p != kRightHandPath))
      return fail(XR_ERROR_PATH_UNSUPPORTED, fn, "activeActionSets[" + std::to_string(i) + "].subactionPath is not a hand");
    hands[*p == kLeftHandPath ? kSlotLeft : kSlotRight] = true;
  }
  s->active_sets = std::move(active);
  const XrTime now = session_now(inst, *s);
  const TrackedState& tracked = inst.script.at(sync_frame(*s));
  for (auto& [action_id, slots] : s->action_states) {
    const Action* action = runtime().actions.find(action_id);
    if (action == nullptr) continue;
    for (int slot = kSlotAny; slot <= kSlotRight; ++slot) {
      const ActionSlotState prev = slots[slot];
      ActionSlotState next = read_slot(*s, *action, action_id, slot, tracked);
      if (next.active) {
        next.changed = prev.active && !same_value(*action, prev, next);
        next.last_change = (next.changed || !prev.active) ? now : prev.last_change;
      }
      slots[slot] = next;
    }
  }
  return with_health(*s, s->state == XR_SESSION_STATE_FOCUSED ? XR_SUCCESS : XR_SESSION_NOT_FOCUSED);
}

namespace {

// The three value-carrying getters differ only in their types and the value they copy.
template <class State, class Copy>
XrResult read_value_state(const char* fn, XrSession session, const XrActionStateGetInfo* info, XrActionType type,
                          XrStructureType state_type, const char* state_name, State* state, Copy copy) {
  const auto lock = lock_runtime();
  const ActionSlotState* st = nullptr;
  Session* s = nullptr;
  if (const XrResult r = get_state(fn, session, info, type, &st, &s); XR_FAILED(r)) return r;
  if (!typed(state, state_type))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, std::string("state must be an ") + state_name);
  copy(*st, *state);
  state->changedSinceLastSync = st->changed;
  state->lastChangeTime = st->last_change;
  state->isActive = st->active;
  return with_health(*s, XR_SUCCESS);
}

}  // namespace

XrResult xrGetActionStateBoolean(XrSession session, const XrActionStateGetInfo* info, XrActionStateBoolean* state) {
  return read_value_state("xrGetActionStateBoolean", session, info, XR_ACTION_TYPE_BOOLEAN_INPUT,
                          XR_TYPE_ACTION_STATE_BOOLEAN, "XrActionStateBoolean", state,
                          [](const ActionSlotState& st, XrActionStateBoolean& out) { out.currentState = st.boolean; });
}

XrResult xrGetActionStateFloat(XrSession session, const XrActionStateGetInfo* info, XrActionStateFloat* state) {
  return read_value_state("xrGetActionStateFloat", session, info, XR_ACTION_TYPE_FLOAT_INPUT,
                          XR_TYPE_ACTION_STATE_FLOAT, "XrActionStateFloat", state,
                          [](const ActionSlotState& st, XrActionStateFloat& out) { out.currentState = st.value; });
}

XrResult xrGetActionStateVector2f(XrSession session, const XrActionStateGetInfo* info, XrActionStateVector2f* state) {
  return read_value_state("xrGetActionStateVector2f", session, info, XR_ACTION_TYPE_VECTOR2F_INPUT,
                          XR_TYPE_ACTION_STATE_VECTOR2F, "XrActionStateVector2f", state,
                          [](const ActionSlotState& st, XrActionStateVector2f& out) { out.currentState = st.vector; });
}

XrResult xrGetActionStatePose(XrSession session, const XrActionStateGetInfo* info, XrActionStatePose* state) {
  const char* fn = "xrGetActionStatePose";
  const auto lock = lock_runtime();
  const ActionSlotState* st = nullptr;
  Session* s = nullptr;
  if (const XrResult r = get_state(fn, session, info, XR_ACTION_TYPE_POSE_INPUT, &st, &s); XR_FAILED(r)) return r;
  if (!typed(state, XR_TYPE_ACTION_STATE_POSE)) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "state must be an XrActionStatePose");
  state->isActive = st->active;
  return with_health(*s, XR_SUCCESS);
}

namespace {

// What xrApplyHapticFeedback and xrStopHapticFeedback both check, as the spec asks; the
// headless controllers have no motors, so a request that passes has no effect.
// `feedback_ok` is false for an apply whose feedback is not an XrHapticVibration.
XrResult check_haptic(const char* fn, XrSession session, const XrHapticActionInfo* info, bool feedback_ok) {
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(info, XR_TYPE_HAPTIC_ACTION_INFO) || !feedback_ok)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "hapticActionInfo (and for an apply an XrHapticVibration) is required");
  const Action* action = find(info->action);
  if (action == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (action->type != XR_ACTION_TYPE_VIBRATION_OUTPUT) return fail(XR_ERROR_ACTION_TYPE_MISMATCH, fn, "not a vibration action");
  if (!attached_to(*s, *action)) return fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, fn, "the action's set is not attached");
  if (subaction_slot(*runtime().instances.find(s->instance_id), *action, info->subactionPath) < 0)
    return fail(XR_ERROR_PATH_UNSUPPORTED, fn, "subactionPath is not one of the action's subaction paths");
  return with_health(*s, s->state == XR_SESSION_STATE_FOCUSED ? XR_SUCCESS : XR_SESSION_NOT_FOCUSED);
}

}  // namespace

XrResult xrApplyHapticFeedback(XrSession session, const XrHapticActionInfo* info, const XrHapticBaseHeader* feedback) {
  const auto lock = lock_runtime();
  return check_haptic("xrApplyHapticFeedback", session, info, typed(feedback, XR_TYPE_HAPTIC_VIBRATION));
}

XrResult xrStopHapticFeedback(XrSession session, const XrHapticActionInfo* info) {
  const auto lock = lock_runtime();
  return check_haptic("xrStopHapticFeedback", session, info, true);
}

}  // namespace gauss::xr_headless
