#pragma once
// gauss-xr's frame loop: the session's events and frames, the shared client runtime
// rendering both eyes into the swapchain images, the controller's queries.
#include "options.h"

namespace gauss::xr_app {

// Runs until the session exits (by the runtime, or after --max-frames). Returns the
// process exit status; errors are printed.
int run_headset(const XrOptions& options);

}  // namespace gauss::xr_app
