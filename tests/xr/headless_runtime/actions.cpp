// Action sets, actions, suggested bindings and their attachment to a session. The current
// interaction profile is chosen at xrAttachSessionActionSets: Touch if the app suggested
// bindings for it, else the simple controller, else none (actions then stay inactive);
// an XrEventDataInteractionProfileChanged tells the app.
#include <algorithm>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

// Action and action-set names: the path-component characters, non-empty.
bool valid_name(const char* name, std::size_t max) {
  const std::size_t n = strnlen(name, max);
  if (n == 0 || n == max) return false;
  return std::all_of(name, name + n, [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.';
  });
}

bool valid_localized(const char* name, std::size_t max) {
  const std::size_t n = strnlen(name, max);
  return n > 0 && n < max;
}

}  // namespace

int subaction_slot(const Instance& instance, const Action& action, XrPath path) {
  if (path == XR_NULL_PATH) return kSlotAny;
  if (std::find(action.subaction_paths.begin(), action.subaction_paths.end(), path) == action.subaction_paths.end()) return -1;
  return *instance.paths.lookup(path) == kLeftHandPath ? kSlotLeft : kSlotRight;
}

bool attached_to(const Session& session, const Action& action) {
  return std::find(session.attached_sets.begin(), session.attached_sets.end(), action.set_id) != session.attached_sets.end();
}

XrResult xrCreateActionSet(XrInstance instance, const XrActionSetCreateInfo* create_info, XrActionSet* action_set) {
  const char* fn = "xrCreateActionSet";
  const auto lock = lock_runtime();
  if (find(instance) == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(create_info, XR_TYPE_ACTION_SET_CREATE_INFO) || action_set == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrActionSetCreateInfo and actionSet non-null");
  if (!valid_name(create_info->actionSetName, XR_MAX_ACTION_SET_NAME_SIZE))
    return fail(XR_ERROR_NAME_INVALID, fn, "actionSetName must be lower-case letters, digits, '-', '_' or '.'");
  if (!valid_localized(create_info->localizedActionSetName, XR_MAX_LOCALIZED_ACTION_SET_NAME_SIZE))
    return fail(XR_ERROR_LOCALIZED_NAME_INVALID, fn, "localizedActionSetName is empty");
  const std::uint64_t inst_id = to_id(instance);
  for (std::uint64_t id : runtime().action_sets.ids_where([&](const ActionSet& s) { return s.instance_id == inst_id; })) {
    const ActionSet& other = *runtime().action_sets.find(id);
    if (other.name == create_info->actionSetName) return fail(XR_ERROR_NAME_DUPLICATED, fn, other.name + " exists");
    if (other.localized_name == create_info->localizedActionSetName)
      return fail(XR_ERROR_LOCALIZED_NAME_DUPLICATED, fn, other.localized_name + " exists");
  }
  auto set = std::make_unique<ActionSet>();
  set->instance_id = inst_id;
  set->name = create_info->actionSetName;
  set->localized_name = create_info->localizedActionSetName;
  set->priority = create_info->priority;
  *action_set = to_handle<XrActionSet>(runtime().action_sets.insert(std::move(set)));
  return XR_SUCCESS;
}

void destroy_action_set(std::uint64_t set_id) {
  Runtime& rt = runtime();
  for (std::uint64_t a : rt.actions.ids_where([&](const Action& x) { return x.set_id == set_id; })) rt.actions.remove(a);
  rt.action_sets.remove(set_id);
}

XrResult xrDestroyActionSet(XrActionSet action_set) {
  const auto lock = lock_runtime();
  if (find(action_set) == nullptr) return XR_ERROR_HANDLE_INVALID;
  destroy_action_set(to_id(action_set));
  return XR_SUCCESS;
}

XrResult xrCreateAction(XrActionSet action_set, const XrActionCreateInfo* create_info, XrAction* action) {
  const char* fn = "xrCreateAction";
  const auto lock = lock_runtime();
  ActionSet* set = find(action_set);
  if (set == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(create_info, XR_TYPE_ACTION_CREATE_INFO) || action == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrActionCreateInfo and action non-null");
  if (set->attached) return fail(XR_ERROR_ACTIONSETS_ALREADY_ATTACHED, fn, "the action set is attached to a session");
  if (!valid_name(create_info->actionName, XR_MAX_ACTION_NAME_SIZE))
    return fail(XR_ERROR_NAME_INVALID, fn, "actionName must be lower-case letters, digits, '-', '_' or '.'");
  if (!valid_localized(create_info->localizedActionName, XR_MAX_LOCALIZED_ACTION_NAME_SIZE))
    return fail(XR_ERROR_LOCALIZED_NAME_INVALID, fn, "localizedActionName is empty");
  switch (create_info->actionType) {
    case XR_ACTION_TYPE_BOOLEAN_INPUT:
    case XR_ACTION_TYPE_FLOAT_INPUT:
    case XR_ACTION_TYPE_VECTOR2F_INPUT:
    case XR_ACTION_TYPE_POSE_INPUT:
    case XR_ACTION_TYPE_VIBRATION_OUTPUT: break;
    default: return fail(XR_ERROR_VALIDATION_FAILURE, fn, "unknown actionType");
  }
  const std::uint64_t set_id = to_id(action_set);
  for (std::uint64_t id : runtime().actions.ids_where([&](const Action& a) { return a.set_id == set_id; })) {
    const Action& other = *runtime().actions.find(id);
    if (other.name == create_info->actionName) return fail(XR_ERROR_NAME_DUPLICATED, fn, other.name + " exists in the set");
    if (other.localized_name == create_info->localizedActionName)
      return fail(XR_ERROR_LOCALIZED_NAME_DUPLICATED, fn, other.localized_name + " exists in the set");
  }
  const Instance& inst = *runtime().instances.find(set->instance_id);
  if (create_info->countSubactionPaths > 0 && create_info->subactionPaths == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "countSubactionPaths > 0 but subactionPaths is null");
  std::vector<XrPath> subs;
  for (std::uint32_t i = 0; i < create_info->countSubactionPaths; ++i) {
    const XrPath p = create_info->subactionPaths[i];
    const std::string* str = inst.paths.lookup(p);
    if (str == nullptr) return fail(XR_ERROR_PATH_INVALID, fn, "subactionPaths[" + std::to_string(i) + "] is not a path");
    if (*str != kLeftHandPath && *str != kRightHandPath)
      return fail(XR_ERROR_PATH_UNSUPPORTED, fn, *str + ": only /user/hand/left and /user/hand/right are subaction paths here");
    if (std::find(subs.begin(), subs.end(), p) != subs.end())
      return fail(XR_ERROR_VALIDATION_FAILURE, fn, *str + " is listed twice");
    subs.push_back(p);
  }
  auto a = std::make_unique<Action>();
  a->instance_id = set->instance_id;
  a->set_id = set_id;
  a->name = create_info->actionName;
  a->localized_name = create_info->localizedActionName;
  a->type = create_info->actionType;
  a->subaction_paths = std::move(subs);
  *action = to_handle<XrAction>(runtime().actions.insert(std::move(a)));
  return XR_SUCCESS;
}

XrResult xrDestroyAction(XrAction action) {
  const auto lock = lock_runtime();
  if (find(action) == nullptr) return XR_ERROR_HANDLE_INVALID;
  runtime().actions.remove(to_id(action));
  return XR_SUCCESS;
}

XrResult xrSuggestInteractionProfileBindings(XrInstance instance, const XrInteractionProfileSuggestedBinding* suggested) {
  const char* fn = "xrSuggestInteractionProfileBindings";
  const auto lock = lock_runtime();
  Instance* inst = find(instance);
  if (inst == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(suggested, XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "suggestedBindings must be an XrInteractionProfileSuggestedBinding");
  if (inst->action_sets_attached)
    return fail(XR_ERROR_ACTIONSETS_ALREADY_ATTACHED, fn, "bindings are fixed once action sets are attached");
  const std::string* profile = inst->paths.lookup(suggested->interactionProfile);
  if (profile == nullptr) return fail(XR_ERROR_PATH_INVALID, fn, "interactionProfile is not a path");
  if (!known_profile(*profile)) return fail(XR_ERROR_PATH_UNSUPPORTED, fn, *profile + " is not a profile of this runtime");
  if (suggested->countSuggestedBindings == 0 || suggested->suggestedBindings == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "no bindings given");
  std::vector<SuggestedBinding> bindings;
  for (std::uint32_t i = 0; i < suggested->countSuggestedBindings; ++i) {
    const XrActionSuggestedBinding& b = suggested->suggestedBindings[i];
    const Action* action = find(b.action);
    if (action == nullptr || action->instance_id != to_id(instance)) return XR_ERROR_HANDLE_INVALID;
    const std::string* path = inst->paths.lookup(b.binding);
    if (path == nullptr) return fail(XR_ERROR_PATH_INVALID, fn, "suggestedBindings[" + std::to_string(i) + "].binding is not a path");
    const auto target = resolve_binding(*profile, *path);
    if (!target) return fail(XR_ERROR_PATH_UNSUPPORTED, fn, *path + " is not an input of " + *profile);
    if (!action_accepts(action->type, target->kind))
      return fail(XR_ERROR_PATH_UNSUPPORTED, fn, *path + " cannot drive action " + action->name + " (type mismatch)");
    bindings.push_back(SuggestedBinding{to_id(b.action), b.binding, *target});
  }
  inst->suggested_bindings[suggested->interactionProfile] = std::move(bindings);
  return XR_SUCCESS;
}

XrResult xrAttachSessionActionSets(XrSession session, const XrSessionActionSetsAttachInfo* attach_info) {
  const char* fn = "xrAttachSessionActionSets";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(attach_info, XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO) || attach_info->countActionSets == 0 ||
      attach_info->actionSets == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "attachInfo must be an XrSessionActionSetsAttachInfo with action sets");
  if (s->actions_attached) return fail(XR_ERROR_ACTIONSETS_ALREADY_ATTACHED, fn, "this session already attached its sets");
  std::vector<std::uint64_t> sets;
  for (std::uint32_t i = 0; i < attach_info->countActionSets; ++i) {
    const ActionSet* set = find(attach_info->actionSets[i]);
    if (set == nullptr || set->instance_id != s->instance_id) return XR_ERROR_HANDLE_INVALID;
    sets.push_back(to_id(attach_info->actionSets[i]));
  }
  Instance& inst = *runtime().instances.find(s->instance_id);
  for (std::uint64_t id : sets) runtime().action_sets.find(id)->attached = true;
  inst.action_sets_attached = true;
  s->actions_attached = true;
  s->attached_sets = sets;

  // Live bindings of the attached actions in one profile.
  auto bound = [&](XrPath profile) {
    std::vector<SuggestedBinding> out;
    auto it = inst.suggested_bindings.find(profile);
    if (it == inst.suggested_bindings.end()) return out;
    for (const SuggestedBinding& b : it->second) {
      const Action* a = runtime().actions.find(b.action_id);
      if (a != nullptr && attached_to(*s, *a)) out.push_back(b);
    }
    return out;
  };
  const XrPath touch = inst.paths.intern(kTouchControllerProfile);
  const XrPath simple = inst.paths.intern(kSimpleControllerProfile);
  std::vector<SuggestedBinding> chosen = bound(touch);
  s->profile = touch;
  if (chosen.empty()) {
    chosen = bound(simple);
    s->profile = chosen.empty() ? XR_NULL_PATH : simple;
  }
  for (const SuggestedBinding& b : chosen) s->bindings[b.action_id].push_back(b);
  for (std::uint64_t id : runtime().actions.ids_where([&](const Action& a) { return attached_to(*s, a); }))
    s->action_states[id] = {};
  if (s->profile != XR_NULL_PATH) {
    PendingEvent ev;
    ev.session_id = to_id(session);
    auto* changed = reinterpret_cast<XrEventDataInteractionProfileChanged*>(&ev.data);
    changed->type = XR_TYPE_EVENT_DATA_INTERACTION_PROFILE_CHANGED;
    changed->next = nullptr;
    changed->session = session;
    queue_event(inst, ev);
  }
  return with_health(*s, XR_SUCCESS);
}

XrResult xrGetCurrentInteractionProfile(XrSession session, XrPath top_level_user_path, XrInteractionProfileState* profile) {
  const char* fn = "xrGetCurrentInteractionProfile";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!s->actions_attached) return fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, fn, "no action sets are attached yet");
  if (!typed(profile, XR_TYPE_INTERACTION_PROFILE_STATE))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "interactionProfile must be an XrInteractionProfileState");
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const std::string* user = inst.paths.lookup(top_level_user_path);
  if (user == nullptr) return fail(XR_ERROR_PATH_INVALID, fn, "topLevelUserPath is not a path");
  if (*user == kLeftHandPath || *user == kRightHandPath) {
    profile->interactionProfile = s->profile;
  } else if (*user == "/user/head" || *user == "/user/gamepad") {
    profile->interactionProfile = XR_NULL_PATH;
  } else {
    return fail(XR_ERROR_PATH_UNSUPPORTED, fn, *user + " is not a top-level user path");
  }
  return with_health(*s, XR_SUCCESS);
}

XrResult xrEnumerateBoundSourcesForAction(XrSession session, const XrBoundSourcesForActionEnumerateInfo* info,
                                          uint32_t capacity, uint32_t* count, XrPath* sources) {
  const char* fn = "xrEnumerateBoundSourcesForAction";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(info, XR_TYPE_BOUND_SOURCES_FOR_ACTION_ENUMERATE_INFO))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "enumerateInfo must be an XrBoundSourcesForActionEnumerateInfo");
  const Action* action = find(info->action);
  if (action == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!attached_to(*s, *action)) return fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, fn, "the action's set is not attached");
  std::vector<XrPath> paths;
  if (auto it = s->bindings.find(to_id(info->action)); it != s->bindings.end())
    for (const SuggestedBinding& b : it->second) paths.push_back(b.binding);
  const XrResult r = two_call(fn, capacity, count, sources == nullptr, static_cast<std::uint32_t>(paths.size()),
                              [&](std::uint32_t i) {
                                sources[i] = paths[i];
                                return XR_SUCCESS;
                              });
  return XR_FAILED(r) ? r : with_health(*s, r);
}

XrResult xrGetInputSourceLocalizedName(XrSession session, const XrInputSourceLocalizedNameGetInfo* info, uint32_t capacity,
                                       uint32_t* count, char* buffer) {
  const char* fn = "xrGetInputSourceLocalizedName";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(info, XR_TYPE_INPUT_SOURCE_LOCALIZED_NAME_GET_INFO) || info->whichComponents == 0)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "getInfo must be an XrInputSourceLocalizedNameGetInfo with components");
  if (!s->actions_attached) return fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, fn, "no action sets are attached yet");
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const std::string* source = inst.paths.lookup(info->sourcePath);
  if (source == nullptr) return fail(XR_ERROR_PATH_INVALID, fn, "sourcePath is not a path");
  const std::string* profile = inst.paths.lookup(s->profile);
  const auto target = profile ? resolve_binding(*profile, *source) : std::nullopt;
  if (!target) return fail(XR_ERROR_PATH_UNSUPPORTED, fn, *source + " is not an input of the current interaction profile");
  std::string name;
  auto add = [&](const char* part) { name += (name.empty() ? "" : " ") + std::string(part); };
  if (info->whichComponents & XR_INPUT_SOURCE_LOCALIZED_NAME_USER_PATH_BIT) add(hand_display_name(target->hand));
  if (info->whichComponents & XR_INPUT_SOURCE_LOCALIZED_NAME_INTERACTION_PROFILE_BIT) add(profile_display_name(*profile));
  if (info->whichComponents & XR_INPUT_SOURCE_LOCALIZED_NAME_COMPONENT_BIT) add(input_display_name(target->input, target->hand));
  const auto n = static_cast<std::uint32_t>(name.size() + 1);
  const XrResult r = two_call(fn, capacity, count, buffer == nullptr, n, [&](std::uint32_t i) {
    buffer[i] = i + 1 < n ? name[i] : '\0';
    return XR_SUCCESS;
  });
  return XR_FAILED(r) ? r : with_health(*s, r);
}

}  // namespace gauss::xr_headless
