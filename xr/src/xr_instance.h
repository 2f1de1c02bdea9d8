#pragma once
// The OpenXR instance both the runtime probe (xr_runtime.h) and the headset session
// (xr_session.h) open: the runtime must be present and offer XR_KHR_vulkan_enable2.
#include <string>

#include <openxr/openxr.h>

#include "gauss/engine/result.h"

namespace gauss::xr::detail {

struct OpenedInstance {
  XrInstance instance{XR_NULL_HANDLE};
  bool depth_layer{false};  // XR_KHR_composition_layer_depth enabled
};

// Creates an instance with XR_KHR_vulkan_enable2 and, when `want_depth_layer` and the
// runtime offers it, XR_KHR_composition_layer_depth. Errors name what is missing: no
// runtime (and how to point at one), or a runtime without the Vulkan extension.
Expected<OpenedInstance> open_instance(const std::string& app_name, bool want_depth_layer);

}  // namespace gauss::xr::detail
