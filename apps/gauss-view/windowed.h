#pragma once
// gauss-view's window: GLFW + swapchain + ImGui panels over the same ViewSource the
// headless mode uses (see window.h for the presentation layer).
#include "options.h"

namespace gauss::view {

// Opens the window (a clear error naming --headless when there is no display), creates
// the Vulkan context for it, runs the frame loop until the window closes (or
// --exit-after frames). Exit status: 0, or 1 on an error (printed).
int run_windowed(const ViewOptions& opts);

}  // namespace gauss::view
