// The loader's way in: xrNegotiateLoaderRuntimeInterface (the library's only exported
// symbol) hands the loader xrGetInstanceProcAddr, which resolves every other function.
//
// Debian's OpenXR SDK has no loader_interfaces.h, so the negotiation structs are declared
// here exactly as the OpenXR loader specification ("Runtime Interface Negotiation")
// defines them.
#include <cstring>
#include <exception>
#include <new>
#include <string_view>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

extern "C" {

enum XrLoaderInterfaceStructs {
  XR_LOADER_INTERFACE_STRUCT_UNINTIALIZED = 0,
  XR_LOADER_INTERFACE_STRUCT_LOADER_INFO,
  XR_LOADER_INTERFACE_STRUCT_API_LAYER_REQUEST,
  XR_LOADER_INTERFACE_STRUCT_RUNTIME_REQUEST,
  XR_LOADER_INTERFACE_STRUCT_API_LAYER_CREATE_INFO,
  XR_LOADER_INTERFACE_STRUCT_API_LAYER_NEXT_INFO,
  XR_LOADER_INTERFACE_STRUCTS_MAX_ENUM = 0x7FFFFFFF
};

#define XR_CURRENT_LOADER_RUNTIME_VERSION 1
#define XR_LOADER_INFO_STRUCT_VERSION 1
#define XR_RUNTIME_INFO_STRUCT_VERSION 1

struct XrNegotiateLoaderInfo {
  XrLoaderInterfaceStructs structType;  // XR_LOADER_INTERFACE_STRUCT_LOADER_INFO
  uint32_t structVersion;               // XR_LOADER_INFO_STRUCT_VERSION
  size_t structSize;                    // sizeof(XrNegotiateLoaderInfo)
  uint32_t minInterfaceVersion;
  uint32_t maxInterfaceVersion;
  XrVersion minApiVersion;
  XrVersion maxApiVersion;
};

struct XrNegotiateRuntimeRequest {
  XrLoaderInterfaceStructs structType;  // XR_LOADER_INTERFACE_STRUCT_RUNTIME_REQUEST
  uint32_t structVersion;               // XR_RUNTIME_INFO_STRUCT_VERSION
  size_t structSize;                    // sizeof(XrNegotiateRuntimeRequest)
  uint32_t runtimeInterfaceVersion;     // filled in by the runtime
  XrVersion runtimeApiVersion;          // filled in by the runtime
  PFN_xrGetInstanceProcAddr getInstanceProcAddr;  // filled in by the runtime
};

__attribute__((visibility("default"))) XrResult xrNegotiateLoaderRuntimeInterface(
    const XrNegotiateLoaderInfo* loader_info, XrNegotiateRuntimeRequest* runtime_request);

}  // extern "C"

namespace gauss::xr_headless {
namespace {

// Exceptions never cross the C boundary: allocation failure becomes
// XR_ERROR_OUT_OF_MEMORY, anything else XR_ERROR_RUNTIME_FAILURE with the reason printed.
template <auto F>
struct Guarded;

template <class... Args, XrResult (*F)(Args...)>
struct Guarded<F> {
  static XrResult XRAPI_CALL call(Args... args) noexcept {
    try {
      return F(args...);
    } catch (const std::bad_alloc&) {
      return XR_ERROR_OUT_OF_MEMORY;
    } catch (const std::exception& e) {
      return fail(XR_ERROR_RUNTIME_FAILURE, "runtime", std::string("internal error: ") + e.what());
    } catch (...) {
      return fail(XR_ERROR_RUNTIME_FAILURE, "runtime", "internal error");
    }
  }
};

enum class Needs { kNothing, kInstance, kVulkanEnable2 };

struct Entry {
  std::string_view name;
  PFN_xrVoidFunction function;
  Needs needs;
};

#define GAUSS_XR_HEADLESS_ENTRY(fn, needs) \
  Entry { #fn, reinterpret_cast<PFN_xrVoidFunction>(&Guarded<&fn>::call), needs }

// The functions callable without an instance, then the core functions, then extensions.
const Entry kEntries[] = {
    GAUSS_XR_HEADLESS_ENTRY(xrGetInstanceProcAddr, Needs::kNothing),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateApiLayerProperties, Needs::kNothing),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateInstanceExtensionProperties, Needs::kNothing),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateInstance, Needs::kNothing),
    GAUSS_XR_HEADLESS_ENTRY(xrDestroyInstance, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetInstanceProperties, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrPollEvent, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrResultToString, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrStructureTypeToString, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetSystem, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetSystemProperties, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateEnvironmentBlendModes, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateSession, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrDestroySession, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateReferenceSpaces, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateReferenceSpace, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetReferenceSpaceBoundsRect, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateActionSpace, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrLocateSpace, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrDestroySpace, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateViewConfigurations, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetViewConfigurationProperties, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateViewConfigurationViews, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateSwapchainFormats, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateSwapchain, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrDestroySwapchain, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateSwapchainImages, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrAcquireSwapchainImage, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrWaitSwapchainImage, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrReleaseSwapchainImage, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrBeginSession, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEndSession, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrRequestExitSession, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrWaitFrame, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrBeginFrame, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEndFrame, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrLocateViews, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrStringToPath, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrPathToString, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateActionSet, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrDestroyActionSet, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateAction, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrDestroyAction, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrSuggestInteractionProfileBindings, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrAttachSessionActionSets, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetCurrentInteractionProfile, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetActionStateBoolean, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetActionStateFloat, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetActionStateVector2f, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetActionStatePose, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrSyncActions, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrEnumerateBoundSourcesForAction, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetInputSourceLocalizedName, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrApplyHapticFeedback, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrStopHapticFeedback, Needs::kInstance),
    GAUSS_XR_HEADLESS_ENTRY(xrGetVulkanGraphicsRequirements2KHR, Needs::kVulkanEnable2),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateVulkanInstanceKHR, Needs::kVulkanEnable2),
    GAUSS_XR_HEADLESS_ENTRY(xrGetVulkanGraphicsDevice2KHR, Needs::kVulkanEnable2),
    GAUSS_XR_HEADLESS_ENTRY(xrCreateVulkanDeviceKHR, Needs::kVulkanEnable2),
};

#undef GAUSS_XR_HEADLESS_ENTRY

}  // namespace

XrResult xrGetInstanceProcAddr(XrInstance instance, const char* name, PFN_xrVoidFunction* function) {
  if (function == nullptr || name == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetInstanceProcAddr", "null name or function pointer");
  *function = nullptr;
  const auto lock = lock_runtime();
  const Instance* inst = nullptr;
  if (instance != XR_NULL_HANDLE) {
    inst = find(instance);
    if (inst == nullptr) return fail(XR_ERROR_HANDLE_INVALID, "xrGetInstanceProcAddr", "unknown XrInstance");
  }
  for (const Entry& e : kEntries) {
    if (e.name != name) continue;
    // Without an instance only the pre-instance functions resolve (spec: xrGetInstanceProcAddr).
    if (inst == nullptr && e.needs != Needs::kNothing) return XR_ERROR_HANDLE_INVALID;
    if (e.needs == Needs::kVulkanEnable2 && !inst->vulkan_enable2) return XR_ERROR_FUNCTION_UNSUPPORTED;
    *function = e.function;
    return XR_SUCCESS;
  }
  // Not implemented (the loader asks for every function it knows; this is no error).
  return XR_ERROR_FUNCTION_UNSUPPORTED;
}

}  // namespace gauss::xr_headless

XrResult xrNegotiateLoaderRuntimeInterface(const XrNegotiateLoaderInfo* loader_info,
                                           XrNegotiateRuntimeRequest* runtime_request) {
  using gauss::xr_headless::fail;
  const char* fn = "xrNegotiateLoaderRuntimeInterface";
  if (loader_info == nullptr || runtime_request == nullptr)
    return fail(XR_ERROR_INITIALIZATION_FAILED, fn, "null loader info or runtime request");
  if (loader_info->structType != XR_LOADER_INTERFACE_STRUCT_LOADER_INFO ||
      loader_info->structVersion != XR_LOADER_INFO_STRUCT_VERSION ||
      loader_info->structSize != sizeof(XrNegotiateLoaderInfo))
    return fail(XR_ERROR_INITIALIZATION_FAILED, fn, "unexpected XrNegotiateLoaderInfo (type, version or size)");
  if (runtime_request->structType != XR_LOADER_INTERFACE_STRUCT_RUNTIME_REQUEST ||
      runtime_request->structVersion != XR_RUNTIME_INFO_STRUCT_VERSION ||
      runtime_request->structSize != sizeof(XrNegotiateRuntimeRequest))
    return fail(XR_ERROR_INITIALIZATION_FAILED, fn, "unexpected XrNegotiateRuntimeRequest (type, version or size)");
  if (loader_info->minInterfaceVersion > XR_CURRENT_LOADER_RUNTIME_VERSION ||
      loader_info->maxInterfaceVersion < XR_CURRENT_LOADER_RUNTIME_VERSION)
    return fail(XR_ERROR_INITIALIZATION_FAILED, fn, "the loader does not speak runtime interface version 1");
  // The API major versions must match; within 1.x any loader range that reaches 1.0 works.
  if (XR_VERSION_MAJOR(loader_info->minApiVersion) > XR_VERSION_MAJOR(XR_CURRENT_API_VERSION) ||
      XR_VERSION_MAJOR(loader_info->maxApiVersion) < XR_VERSION_MAJOR(XR_CURRENT_API_VERSION))
    return fail(XR_ERROR_INITIALIZATION_FAILED, fn, "the loader's OpenXR API range excludes 1.0");
  runtime_request->runtimeInterfaceVersion = XR_CURRENT_LOADER_RUNTIME_VERSION;
  runtime_request->runtimeApiVersion = XR_CURRENT_API_VERSION;
  runtime_request->getInstanceProcAddr =
      reinterpret_cast<PFN_xrGetInstanceProcAddr>(&gauss::xr_headless::Guarded<&gauss::xr_headless::xrGetInstanceProcAddr>::call);
  return XR_SUCCESS;
}
