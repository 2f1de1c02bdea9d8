#include "interaction_profiles.h"

#include <array>
#include <cmath>
#include <string>

namespace gauss::xr_headless {
namespace {

enum class Sides { kBoth, kLeftOnly, kRightOnly };

struct Component {
  std::string_view profile;
  Sides sides;
  std::string_view path;  // after /user/hand/<side>/
  Input input;
  InputKind kind;
};

constexpr std::string_view kS = kSimpleControllerProfile;
constexpr std::string_view kT = kTouchControllerProfile;

constexpr std::array kComponents{
    Component{kS, Sides::kBoth, "input/select/click", Input::kTriggerClick, InputKind::kBoolean},
    Component{kS, Sides::kBoth, "input/menu/click", Input::kSecondaryClick, InputKind::kBoolean},
    Component{kS, Sides::kBoth, "input/grip/pose", Input::kGripPose, InputKind::kPose},
    Component{kS, Sides::kBoth, "input/aim/pose", Input::kAimPose, InputKind::kPose},
    Component{kS, Sides::kBoth, "output/haptic", Input::kHaptic, InputKind::kHaptic},
    Component{kT, Sides::kLeftOnly, "input/x/click", Input::kPrimaryClick, InputKind::kBoolean},
    Component{kT, Sides::kLeftOnly, "input/x/touch", Input::kPrimaryTouch, InputKind::kBoolean},
    Component{kT, Sides::kLeftOnly, "input/y/click", Input::kSecondaryClick, InputKind::kBoolean},
    Component{kT, Sides::kLeftOnly, "input/y/touch", Input::kSecondaryTouch, InputKind::kBoolean},
    Component{kT, Sides::kLeftOnly, "input/menu/click", Input::kMenuClick, InputKind::kBoolean},
    Component{kT, Sides::kRightOnly, "input/a/click", Input::kPrimaryClick, InputKind::kBoolean},
    Component{kT, Sides::kRightOnly, "input/a/touch", Input::kPrimaryTouch, InputKind::kBoolean},
    Component{kT, Sides::kRightOnly, "input/b/click", Input::kSecondaryClick, InputKind::kBoolean},
    Component{kT, Sides::kRightOnly, "input/b/touch", Input::kSecondaryTouch, InputKind::kBoolean},
    Component{kT, Sides::kRightOnly, "input/system/click", Input::kSystemClick, InputKind::kBoolean},
    Component{kT, Sides::kBoth, "input/squeeze/value", Input::kSqueezeValue, InputKind::kFloat},
    Component{kT, Sides::kBoth, "input/trigger/value", Input::kTriggerValue, InputKind::kFloat},
    Component{kT, Sides::kBoth, "input/trigger/click", Input::kTriggerClick, InputKind::kBoolean},
    Component{kT, Sides::kBoth, "input/trigger/touch", Input::kTriggerTouch, InputKind::kBoolean},
    Component{kT, Sides::kBoth, "input/thumbstick", Input::kThumbstick, InputKind::kVector2},
    Component{kT, Sides::kBoth, "input/thumbstick/x", Input::kThumbstickX, InputKind::kFloat},
    Component{kT, Sides::kBoth, "input/thumbstick/y", Input::kThumbstickY, InputKind::kFloat},
    Component{kT, Sides::kBoth, "input/thumbstick/click", Input::kThumbstickClick, InputKind::kBoolean},
    Component{kT, Sides::kBoth, "input/thumbstick/touch", Input::kThumbstickTouch, InputKind::kBoolean},
    Component{kT, Sides::kBoth, "input/thumbrest/touch", Input::kThumbrestTouch, InputKind::kBoolean},
    Component{kT, Sides::kBoth, "input/grip/pose", Input::kGripPose, InputKind::kPose},
    Component{kT, Sides::kBoth, "input/aim/pose", Input::kAimPose, InputKind::kPose},
    Component{kT, Sides::kBoth, "output/haptic", Input::kHaptic, InputKind::kHaptic},
};

bool side_matches(Sides sides, Hand hand) {
  return sides == Sides::kBoth || (sides == Sides::kLeftOnly) == (hand == Hand::kLeft);
}

}  // namespace

bool known_profile(std::string_view profile) { return profile == kSimpleControllerProfile || profile == kTouchControllerProfile; }

std::optional<BindingTarget> resolve_binding(std::string_view profile, std::string_view binding_path) {
  Hand hand;
  std::string_view rest;
  const std::string left = std::string(kLeftHandPath) + "/";
  const std::string right = std::string(kRightHandPath) + "/";
  if (binding_path.substr(0, left.size()) == left) {
    hand = Hand::kLeft;
    rest = binding_path.substr(left.size());
  } else if (binding_path.substr(0, right.size()) == right) {
    hand = Hand::kRight;
    rest = binding_path.substr(right.size());
  } else {
    return std::nullopt;
  }
  for (const Component& c : kComponents)
    if (c.profile == profile && c.path == rest && side_matches(c.sides, hand)) return BindingTarget{hand, c.input, c.kind};
  return std::nullopt;
}

bool action_accepts(XrActionType type, InputKind kind) {
  switch (type) {
    case XR_ACTION_TYPE_BOOLEAN_INPUT:
    case XR_ACTION_TYPE_FLOAT_INPUT: return kind == InputKind::kBoolean || kind == InputKind::kFloat;
    case XR_ACTION_TYPE_VECTOR2F_INPUT: return kind == InputKind::kVector2;
    case XR_ACTION_TYPE_POSE_INPUT: return kind == InputKind::kPose;
    case XR_ACTION_TYPE_VIBRATION_OUTPUT: return kind == InputKind::kHaptic;
    default: return false;
  }
}

InputValue read_input(const HandState& hand, Input input) {
  InputValue v;
  auto set_bool = [&](bool b) {
    v.boolean = b;
    v.value = b ? 1.0f : 0.0f;
  };
  auto set_float = [&](float f) {
    v.value = f;
    v.boolean = f > kClickThreshold;
  };
  switch (input) {
    case Input::kTriggerValue: set_float(hand.trigger); break;
    case Input::kTriggerClick: set_bool(hand.trigger > kClickThreshold); break;
    case Input::kTriggerTouch: set_bool(hand.trigger > 0.0f); break;
    case Input::kSqueezeValue: set_float(hand.squeeze); break;
    case Input::kPrimaryClick:
    case Input::kPrimaryTouch: set_bool(hand.primary); break;
    case Input::kSecondaryClick:
    case Input::kSecondaryTouch: set_bool(hand.secondary); break;
    case Input::kMenuClick: set_bool(hand.menu); break;
    case Input::kThumbstick: v.vector = hand.thumbstick; break;
    case Input::kThumbstickX: set_float(hand.thumbstick.x); break;
    case Input::kThumbstickY: set_float(hand.thumbstick.y); break;
    case Input::kThumbstickClick: set_bool(hand.thumbstick_click); break;
    case Input::kThumbstickTouch:
      set_bool(hand.thumbstick_click || hand.thumbstick.x != 0.0f || hand.thumbstick.y != 0.0f);
      break;
    case Input::kSystemClick:
    case Input::kThumbrestTouch:
    case Input::kAimPose:
    case Input::kGripPose:
    case Input::kHaptic: break;
  }
  return v;
}

XrPosef read_pose(const HandState& hand, Input input) { return input == Input::kGripPose ? hand.grip : hand.aim; }

const char* hand_display_name(Hand hand) { return hand == Hand::kLeft ? "Left Hand" : "Right Hand"; }

const char* profile_display_name(std::string_view profile) {
  return profile == kTouchControllerProfile ? "Oculus Touch Controller" : "Khronos Simple Controller";
}

const char* input_display_name(Input input, Hand hand) {
  const bool left = hand == Hand::kLeft;
  switch (input) {
    case Input::kAimPose: return "Aim Pose";
    case Input::kGripPose: return "Grip Pose";
    case Input::kTriggerValue:
    case Input::kTriggerClick:
    case Input::kTriggerTouch: return "Trigger";
    case Input::kSqueezeValue: return "Squeeze";
    case Input::kPrimaryClick:
    case Input::kPrimaryTouch: return left ? "X Button" : "A Button";
    case Input::kSecondaryClick:
    case Input::kSecondaryTouch: return left ? "Y Button" : "B Button";
    case Input::kMenuClick: return "Menu Button";
    case Input::kSystemClick: return "System Button";
    case Input::kThumbstick:
    case Input::kThumbstickX:
    case Input::kThumbstickY:
    case Input::kThumbstickClick:
    case Input::kThumbstickTouch: return "Thumbstick";
    case Input::kThumbrestTouch: return "Thumbrest";
    case Input::kHaptic: return "Haptics";
  }
  return "Input";
}

}  // namespace gauss::xr_headless
