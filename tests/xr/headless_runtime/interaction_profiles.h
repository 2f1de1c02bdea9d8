#pragma once
// The two interaction profiles the headless controllers speak, their input paths, and how
// each input reads the scripted controller state (script.h).
//
//   /interaction_profiles/khr/simple_controller   select/click = trigger > 0.5,
//       menu/click = b (right) / y (left), grip/pose, aim/pose, output/haptic
//   /interaction_profiles/oculus/touch_controller the spec's component list, plus
//       trigger/click (trigger > 0.5), which real Touch controllers lack
//
// system/click and thumbrest/touch exist (so bindings to them are accepted) but the
// script cannot press them: they always read false.
#include <optional>
#include <string_view>

#include "script.h"
#include "xr_headers.h"

namespace gauss::xr_headless {

inline constexpr std::string_view kSimpleControllerProfile = "/interaction_profiles/khr/simple_controller";
inline constexpr std::string_view kTouchControllerProfile = "/interaction_profiles/oculus/touch_controller";
inline constexpr std::string_view kLeftHandPath = "/user/hand/left";
inline constexpr std::string_view kRightHandPath = "/user/hand/right";

enum class Hand { kLeft, kRight };

enum class Input {
  kAimPose, kGripPose,
  kTriggerValue, kTriggerClick, kTriggerTouch,
  kSqueezeValue,
  kPrimaryClick, kPrimaryTouch,      // a / x
  kSecondaryClick, kSecondaryTouch,  // b / y
  kMenuClick, kSystemClick,
  kThumbstick, kThumbstickX, kThumbstickY, kThumbstickClick, kThumbstickTouch, kThumbrestTouch,
  kHaptic,
};

enum class InputKind { kBoolean, kFloat, kVector2, kPose, kHaptic };

struct BindingTarget {
  Hand hand{Hand::kRight};
  Input input{Input::kAimPose};
  InputKind kind{InputKind::kPose};
};

bool known_profile(std::string_view profile);

// What `binding_path` (e.g. "/user/hand/right/input/trigger/value") names in `profile`,
// or nullopt if the profile has no such input.
std::optional<BindingTarget> resolve_binding(std::string_view profile, std::string_view binding_path);

// Whether an action of `type` may be bound to an input of `kind` (booleans and floats
// convert into each other, as the spec allows; nothing else does).
bool action_accepts(XrActionType type, InputKind kind);

// The current value of a non-pose input.
struct InputValue {
  bool boolean{false};
  float value{0.0f};
  XrVector2f vector{0.0f, 0.0f};
};
InputValue read_input(const HandState& hand, Input input);

// The input's pose in STAGE space (aim or grip).
XrPosef read_pose(const HandState& hand, Input input);

// Localized names for xrGetInputSourceLocalizedName.
const char* hand_display_name(Hand hand);
const char* profile_display_name(std::string_view profile);
const char* input_display_name(Input input, Hand hand);

}  // namespace gauss::xr_headless
