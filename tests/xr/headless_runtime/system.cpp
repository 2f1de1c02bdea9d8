// The one system: a stereo head-mounted display whose view size comes from the script.
#include <cstring>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

// The largest swapchain image the runtime creates (and reports).
constexpr std::uint32_t kMaxImageSize = 4096;

// Common checks: a live instance and our system id.
XrResult check_system(XrInstance instance, XrSystemId system_id, const Instance** out) {
  *out = find(instance);
  if (*out == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (system_id != kSystemId) return XR_ERROR_SYSTEM_INVALID;
  return XR_SUCCESS;
}

}  // namespace

XrResult xrGetSystem(XrInstance instance, const XrSystemGetInfo* get_info, XrSystemId* system_id) {
  const auto lock = lock_runtime();
  if (find(instance) == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(get_info, XR_TYPE_SYSTEM_GET_INFO) || system_id == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetSystem", "getInfo must be an XrSystemGetInfo and systemId non-null");
  if (get_info->formFactor == XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY) {
    *system_id = kSystemId;
    return XR_SUCCESS;
  }
  if (get_info->formFactor == XR_FORM_FACTOR_HANDHELD_DISPLAY) return XR_ERROR_FORM_FACTOR_UNSUPPORTED;
  return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetSystem", "unknown form factor");
}

XrResult xrGetSystemProperties(XrInstance instance, XrSystemId system_id, XrSystemProperties* properties) {
  const auto lock = lock_runtime();
  const Instance* inst = nullptr;
  if (const XrResult r = check_system(instance, system_id, &inst); XR_FAILED(r)) return r;
  if (!typed(properties, XR_TYPE_SYSTEM_PROPERTIES))
    return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetSystemProperties", "properties must be an XrSystemProperties");
  properties->systemId = kSystemId;
  properties->vendorId = 0;
  copy_string(properties->systemName, "headless HMD");
  properties->graphicsProperties.maxSwapchainImageWidth = kMaxImageSize;
  properties->graphicsProperties.maxSwapchainImageHeight = kMaxImageSize;
  properties->graphicsProperties.maxLayerCount = XR_MIN_COMPOSITION_LAYERS_SUPPORTED;
  properties->trackingProperties.orientationTracking = XR_TRUE;
  properties->trackingProperties.positionTracking = XR_TRUE;
  return XR_SUCCESS;
}

XrResult xrEnumerateViewConfigurations(XrInstance instance, XrSystemId system_id, uint32_t capacity, uint32_t* count,
                                       XrViewConfigurationType* types) {
  const auto lock = lock_runtime();
  const Instance* inst = nullptr;
  if (const XrResult r = check_system(instance, system_id, &inst); XR_FAILED(r)) return r;
  return two_call("xrEnumerateViewConfigurations", capacity, count, types == nullptr, 1, [&](std::uint32_t i) {
    types[i] = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
    return XR_SUCCESS;
  });
}

XrResult xrGetViewConfigurationProperties(XrInstance instance, XrSystemId system_id, XrViewConfigurationType type,
                                          XrViewConfigurationProperties* properties) {
  const auto lock = lock_runtime();
  const Instance* inst = nullptr;
  if (const XrResult r = check_system(instance, system_id, &inst); XR_FAILED(r)) return r;
  if (type != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO) return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  if (!typed(properties, XR_TYPE_VIEW_CONFIGURATION_PROPERTIES))
    return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetViewConfigurationProperties",
                "properties must be an XrViewConfigurationProperties");
  properties->viewConfigurationType = type;
  properties->fovMutable = XR_TRUE;  // the app's submitted fov is taken as is (and captured)
  return XR_SUCCESS;
}

XrResult xrEnumerateViewConfigurationViews(XrInstance instance, XrSystemId system_id, XrViewConfigurationType type,
                                           uint32_t capacity, uint32_t* count, XrViewConfigurationView* views) {
  const auto lock = lock_runtime();
  const Instance* inst = nullptr;
  if (const XrResult r = check_system(instance, system_id, &inst); XR_FAILED(r)) return r;
  if (type != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO) return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  return two_call("xrEnumerateViewConfigurationViews", capacity, count, views == nullptr, 2, [&](std::uint32_t i) {
    if (views[i].type != XR_TYPE_VIEW_CONFIGURATION_VIEW)
      return fail(XR_ERROR_VALIDATION_FAILURE, "xrEnumerateViewConfigurationViews",
                  "views[" + std::to_string(i) + "].type is not XR_TYPE_VIEW_CONFIGURATION_VIEW");
    views[i].recommendedImageRectWidth = inst->script.width;
    views[i].recommendedImageRectHeight = inst->script.height;
    views[i].maxImageRectWidth = kMaxImageSize;
    views[i].maxImageRectHeight = kMaxImageSize;
    views[i].recommendedSwapchainSampleCount = 1;
    views[i].maxSwapchainSampleCount = 1;
    return XR_SUCCESS;
  });
}

XrResult xrEnumerateEnvironmentBlendModes(XrInstance instance, XrSystemId system_id, XrViewConfigurationType type,
                                          uint32_t capacity, uint32_t* count, XrEnvironmentBlendMode* modes) {
  const auto lock = lock_runtime();
  const Instance* inst = nullptr;
  if (const XrResult r = check_system(instance, system_id, &inst); XR_FAILED(r)) return r;
  if (type != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO) return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  return two_call("xrEnumerateEnvironmentBlendModes", capacity, count, modes == nullptr, 1, [&](std::uint32_t i) {
    modes[i] = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
    return XR_SUCCESS;
  });
}

}  // namespace gauss::xr_headless
