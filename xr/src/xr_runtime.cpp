#include "gauss/xr/xr_runtime.h"

#include <cstring>
#include <vector>

#include <openxr/openxr.h>

#include "xr_check.h"

namespace gauss::xr {
namespace {

using detail::result_text;
using detail::xr_struct;

// XR_KHR_vulkan_enable2's name, spelled out so this file needs no Vulkan platform headers.
constexpr const char* kVulkanEnable2 = "XR_KHR_vulkan_enable2";

}  // namespace

struct XrRuntime::Handles {
  XrInstance instance{XR_NULL_HANDLE};
  ~Handles() {
    if (instance != XR_NULL_HANDLE) xrDestroyInstance(instance);
  }
};

XrRuntime::~XrRuntime() = default;

Expected<std::unique_ptr<XrRuntime>> XrRuntime::open(const std::string& app_name) {
  std::uint32_t count = 0;
  XrResult r = xrEnumerateInstanceExtensionProperties(nullptr, 0, &count, nullptr);
  if (XR_FAILED(r))
    return Error{"no OpenXR runtime available (" + result_text(XR_NULL_HANDLE, r) +
                 "): install one and make it active (e.g. set XR_RUNTIME_JSON)"};
  std::vector<XrExtensionProperties> exts(count, xr_struct<XrExtensionProperties>(XR_TYPE_EXTENSION_PROPERTIES));
  r = xrEnumerateInstanceExtensionProperties(nullptr, count, &count, exts.data());
  if (XR_FAILED(r)) return Error{"OpenXR: enumerating extensions failed (" + result_text(XR_NULL_HANDLE, r) + ")"};
  bool has_vulkan = false;
  for (const auto& e : exts) has_vulkan |= std::strcmp(e.extensionName, kVulkanEnable2) == 0;
  if (!has_vulkan) return Error{std::string("OpenXR runtime lacks ") + kVulkanEnable2};

  auto rt = std::unique_ptr<XrRuntime>(new XrRuntime());
  rt->handles_ = std::make_unique<Handles>();
  auto ci = xr_struct<XrInstanceCreateInfo>(XR_TYPE_INSTANCE_CREATE_INFO);
  std::strncpy(ci.applicationInfo.applicationName, app_name.c_str(), XR_MAX_APPLICATION_NAME_SIZE - 1);
  std::strncpy(ci.applicationInfo.engineName, "GaussAnything", XR_MAX_ENGINE_NAME_SIZE - 1);
  ci.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
  ci.enabledExtensionCount = 1;
  ci.enabledExtensionNames = &kVulkanEnable2;
  r = xrCreateInstance(&ci, &rt->handles_->instance);
  if (XR_FAILED(r)) return Error{"OpenXR: xrCreateInstance failed (" + result_text(XR_NULL_HANDLE, r) + ")"};
  XrInstance inst = rt->handles_->instance;

  auto props = xr_struct<XrInstanceProperties>(XR_TYPE_INSTANCE_PROPERTIES);
  if (XR_SUCCEEDED(xrGetInstanceProperties(inst, &props))) rt->info_.runtime_name = props.runtimeName;

  auto sgi = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
  sgi.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
  XrSystemId system = XR_NULL_SYSTEM_ID;
  r = xrGetSystem(inst, &sgi, &system);
  if (XR_FAILED(r)) return Error{"OpenXR: no head-mounted display (" + result_text(inst, r) + ")"};
  auto sp = xr_struct<XrSystemProperties>(XR_TYPE_SYSTEM_PROPERTIES);
  if (XR_SUCCEEDED(xrGetSystemProperties(inst, system, &sp))) rt->info_.system_name = sp.systemName;

  std::uint32_t views = 0;
  r = xrEnumerateViewConfigurationViews(inst, system, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 0, &views, nullptr);
  if (XR_FAILED(r) || views != 2) return Error{"OpenXR: the headset offers no primary stereo view configuration"};
  std::vector<XrViewConfigurationView> vcv(views, xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW));
  r = xrEnumerateViewConfigurationViews(inst, system, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, views, &views, vcv.data());
  if (XR_FAILED(r)) return Error{"OpenXR: reading the stereo views failed (" + result_text(inst, r) + ")"};
  rt->info_.recommended_width = vcv[0].recommendedImageRectWidth;
  rt->info_.recommended_height = vcv[0].recommendedImageRectHeight;
  return rt;
}

}  // namespace gauss::xr
