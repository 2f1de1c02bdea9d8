#pragma once
// The headset's controls, as OpenXR actions bound for the Oculus Touch controller (Quest)
// and the KHR simple controller (any runtime): the right hand's aim pose and trigger
// (point and pull: an instance query on the object under the ray), A (next class query),
// B (clear the query) and the thumbstick (each push up or down steps rho). Edges are
// reported once, on the frame the button went down or the stick passed half way.
#include <memory>

#include <openxr/openxr.h>

#include "gauss/engine/result.h"
#include "gauss/xr/xr_pose.h"

namespace gauss::xr {

struct ControllerInput {
  bool aim_valid{false};     // the aim pose is tracked this frame
  XrPose aim;                // in the session's reference space (OpenXR convention)
  float trigger{0.0f};       // 0..1
  bool trigger_pulled{false};  // crossed 0.5 upwards this frame
  bool next_class{false};    // A went down this frame
  bool clear{false};         // B went down this frame
  float stick_y{0.0f};       // -1..1
  int stick_steps{0};        // +1: pushed up past half way this frame, -1: down (one step per push)
};

class Controls {
 public:
  // Creates the action set and actions, suggests both profiles' bindings and attaches the
  // set to `session` (before its first frame). Errors: a failing OpenXR call, named.
  static Expected<std::unique_ptr<Controls>> create(XrInstance instance, XrSession session, XrSpace space);
  ~Controls();
  Controls(const Controls&) = delete;
  Controls& operator=(const Controls&) = delete;

  // Syncs the actions and reads them, the aim located at `time` (the frame's predicted
  // display time). Unfocused sessions read as idle input (OpenXR reports nothing then).
  Expected<ControllerInput> read(XrTime time);

 private:
  Controls() = default;
  XrInstance instance_{XR_NULL_HANDLE};
  XrSession session_{XR_NULL_HANDLE};
  XrSpace space_{XR_NULL_HANDLE};
  XrActionSet set_{XR_NULL_HANDLE};
  XrAction aim_{XR_NULL_HANDLE}, trigger_{XR_NULL_HANDLE}, next_{XR_NULL_HANDLE}, clear_{XR_NULL_HANDLE},
      stick_{XR_NULL_HANDLE};
  XrSpace aim_space_{XR_NULL_HANDLE};
  float last_trigger_{0.0f};
  float last_stick_y_{0.0f};
};

// The ray of an aim pose in the scene (T_scene_space maps the reference space into it, as for
// eye_camera): origin at the pose, along its -z.
void aim_ray(const XrPose& aim, const glm::dmat4& T_scene_space, glm::dvec3& origin, glm::dvec3& direction);

}  // namespace gauss::xr
