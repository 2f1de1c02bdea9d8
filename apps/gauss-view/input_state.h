#pragma once
// Camera input of one display frame, gathered by Window::poll_events() (window.h) and read
// by the camera controls (fly_camera.h, orbit_control.h). Keys and mouse that the UI takes
// (a focused text field, the cursor over a panel) do not reach the camera. No GLFW or
// Vulkan here, so the controls are tested without a window.
#include <optional>

#include "gauss/engine/scene_framing.h"

namespace gauss::view {

struct InputState {
  bool forward{false}, back{false};  // W / S
  bool left{false}, right{false};    // A / D
  bool up{false}, down{false};       // E / Q
  bool fast{false};                  // Shift held
  // F or 1 / 2 / 3 pressed since the previous poll: frame the scene again from the front /
  // side / top (scene_framing.h ViewPreset).
  std::optional<ViewPreset> view;
  bool toggle_orbit{false};          // O pressed since the previous poll: orbit <-> fly
  bool screenshot{false};            // P pressed since the previous poll: write the window as PNG
  // Right mouse button held, pressed over the scene: mouse look. The cursor is hidden and
  // unbounded while it lasts.
  bool looking{false};
  // Cursor motion since the previous poll_events() while looking, in pixels (+x right,
  // +y down); 0 otherwise.
  double look_dx{0.0}, look_dy{0.0};
  // Left / middle button held, pressed over the scene (orbit / pan), and the cursor's
  // motion since the previous poll while it is (pixels, +x right, +y down).
  bool dragging{false}, panning{false};
  double drag_dx{0.0}, drag_dy{0.0};
  // Wheel steps since the previous poll_events() over the scene (+ away from the user).
  double scroll{0.0};
  bool ui_wants_mouse{false}, ui_wants_keyboard{false};
};

}  // namespace gauss::view
