#include "xr_instance.h"

#include <cstring>
#include <vector>

#include "xr_check.h"

namespace gauss::xr::detail {
namespace {

// XR_KHR_vulkan_enable2's name, spelled out so this file needs no Vulkan platform headers.
constexpr const char* kVulkanEnable2 = "XR_KHR_vulkan_enable2";

}  // namespace

Expected<OpenedInstance> open_instance(const std::string& app_name, bool want_depth_layer) {
  std::uint32_t count = 0;
  XrResult r = xrEnumerateInstanceExtensionProperties(nullptr, 0, &count, nullptr);
  if (XR_FAILED(r))
    return Error{"no OpenXR runtime available (" + result_text(XR_NULL_HANDLE, r) +
                 "): install one and make it active, or point XR_RUNTIME_JSON at its manifest"};
  std::vector<XrExtensionProperties> exts(count, xr_struct<XrExtensionProperties>(XR_TYPE_EXTENSION_PROPERTIES));
  if (r = xrEnumerateInstanceExtensionProperties(nullptr, count, &count, exts.data()); XR_FAILED(r))
    return xr_error(XR_NULL_HANDLE, "xrEnumerateInstanceExtensionProperties", r);
  auto offered = [&exts](const char* name) {
    for (const XrExtensionProperties& e : exts)
      if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
  };
  if (!offered(kVulkanEnable2))
    return Error{std::string("the OpenXR runtime does not offer ") + kVulkanEnable2 +
                 ", which this Vulkan renderer needs"};
  OpenedInstance out;
  // The depth layer lets the compositor reproject with depth; taken when offered.
  out.depth_layer = want_depth_layer && offered(XR_KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME);
  const char* enabled[] = {kVulkanEnable2, XR_KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME};
  auto ci = xr_struct<XrInstanceCreateInfo>(XR_TYPE_INSTANCE_CREATE_INFO);
  std::strncpy(ci.applicationInfo.applicationName, app_name.c_str(), XR_MAX_APPLICATION_NAME_SIZE - 1);
  std::strncpy(ci.applicationInfo.engineName, "GaussAnything", XR_MAX_ENGINE_NAME_SIZE - 1);
  ci.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
  ci.enabledExtensionCount = out.depth_layer ? 2 : 1;
  ci.enabledExtensionNames = enabled;
  if (r = xrCreateInstance(&ci, &out.instance); XR_FAILED(r)) return xr_error(XR_NULL_HANDLE, "xrCreateInstance", r);
  return out;
}

}  // namespace gauss::xr::detail
