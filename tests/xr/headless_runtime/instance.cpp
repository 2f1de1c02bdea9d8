// Instance lifetime, the extension list, instance properties, enum strings and paths.
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

struct OfferedExtension {
  const char* name;
  uint32_t version;
};

constexpr OfferedExtension kExtensions[] = {
    {XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME, XR_KHR_vulkan_enable2_SPEC_VERSION},
    {XR_KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME, XR_KHR_composition_layer_depth_SPEC_VERSION},
};

// GAUSS_XR_HEADLESS_NO_VULKAN=1 plays a runtime without Vulkan support (both extensions
// hidden), for the app's "runtime lacks XR_KHR_vulkan_enable2" path. Read at every call,
// since the loader may keep the runtime loaded between instances.
std::uint32_t offered_extension_count() {
  const char* env = std::getenv("GAUSS_XR_HEADLESS_NO_VULKAN");
  const bool none = env != nullptr && std::strcmp(env, "1") == 0;
  return none ? 0 : static_cast<std::uint32_t>(std::size(kExtensions));
}

}  // namespace

XrResult xrEnumerateApiLayerProperties(uint32_t capacity, uint32_t* count, XrApiLayerProperties* properties) {
  // The runtime has no API layers (the loader lists the installed ones itself).
  return two_call("xrEnumerateApiLayerProperties", capacity, count, properties == nullptr, 0,
                  [](std::uint32_t) { return XR_SUCCESS; });
}

XrResult xrEnumerateInstanceExtensionProperties(const char* layer_name, uint32_t capacity, uint32_t* count,
                                                XrExtensionProperties* properties) {
  if (layer_name != nullptr && layer_name[0] != '\0') return XR_ERROR_API_LAYER_NOT_PRESENT;
  return two_call("xrEnumerateInstanceExtensionProperties", capacity, count, properties == nullptr,
                  offered_extension_count(), [&](std::uint32_t i) {
                    if (properties[i].type != XR_TYPE_EXTENSION_PROPERTIES)
                      return fail(XR_ERROR_VALIDATION_FAILURE, "xrEnumerateInstanceExtensionProperties",
                                  "properties[" + std::to_string(i) + "].type is not XR_TYPE_EXTENSION_PROPERTIES");
                    copy_string(properties[i].extensionName, kExtensions[i].name);
                    properties[i].extensionVersion = kExtensions[i].version;
                    return XR_SUCCESS;
                  });
}

XrResult xrCreateInstance(const XrInstanceCreateInfo* create_info, XrInstance* instance) {
  const char* fn = "xrCreateInstance";
  if (!typed(create_info, XR_TYPE_INSTANCE_CREATE_INFO) || instance == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrInstanceCreateInfo and instance non-null");
  if (XR_VERSION_MAJOR(create_info->applicationInfo.apiVersion) != 1)
    return fail(XR_ERROR_API_VERSION_UNSUPPORTED, fn, "only OpenXR 1.x is supported");
  if (create_info->applicationInfo.applicationName[0] == '\0')
    return fail(XR_ERROR_NAME_INVALID, fn, "applicationInfo.applicationName is empty");
  auto inst = std::make_unique<Instance>();
  const std::uint32_t offered = offered_extension_count();
  for (std::uint32_t i = 0; i < create_info->enabledExtensionCount; ++i) {
    const char* name = create_info->enabledExtensionNames[i];
    std::uint32_t k = 0;
    while (k < offered && std::strcmp(kExtensions[k].name, name) != 0) ++k;
    if (k == offered) return fail(XR_ERROR_EXTENSION_NOT_PRESENT, fn, std::string("extension ") + name + " is not offered");
    if (k == 0) inst->vulkan_enable2 = true;
    if (k == 1) inst->composition_layer_depth = true;
  }
  // API layers are the loader's business: it has already put them in front of us.
  if (const char* script = std::getenv("GAUSS_XR_HEADLESS_SCRIPT"); script != nullptr && script[0] != '\0') {
    auto parsed = load_script(script);
    if (!parsed) return fail(XR_ERROR_INITIALIZATION_FAILED, fn, "bad script: " + parsed.message());
    inst->script = std::move(*parsed);
  }
  if (const char* dir = std::getenv("GAUSS_XR_HEADLESS_CAPTURE"); dir != nullptr && dir[0] != '\0')
    inst->capture_dir = dir;
  const auto lock = lock_runtime();
  *instance = to_handle<XrInstance>(runtime().instances.insert(std::move(inst)));
  return XR_SUCCESS;
}

XrResult xrDestroyInstance(XrInstance instance) {
  const auto lock = lock_runtime();
  Runtime& rt = runtime();
  Instance* inst = find(instance);
  if (inst == nullptr) return XR_ERROR_HANDLE_INVALID;
  const std::uint64_t id = to_id(instance);
  if (inst->session_id != 0) destroy_session(inst->session_id);
  for (std::uint64_t set : rt.action_sets.ids_where([&](const ActionSet& s) { return s.instance_id == id; }))
    destroy_action_set(set);
  rt.instances.remove(id);
  return XR_SUCCESS;
}

XrResult xrGetInstanceProperties(XrInstance instance, XrInstanceProperties* properties) {
  const auto lock = lock_runtime();
  if (find(instance) == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(properties, XR_TYPE_INSTANCE_PROPERTIES))
    return fail(XR_ERROR_VALIDATION_FAILURE, "xrGetInstanceProperties", "properties must be an XrInstanceProperties");
  properties->runtimeVersion = XR_MAKE_VERSION(0, 1, 0);
  copy_string(properties->runtimeName, "GaussAnything headless");
  return XR_SUCCESS;
}

XrResult xrResultToString(XrInstance instance, XrResult value, char buffer[XR_MAX_RESULT_STRING_SIZE]) {
  const auto lock = lock_runtime();
  if (find(instance) == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (buffer == nullptr) return XR_ERROR_VALIDATION_FAILURE;
  std::string text;
  if (const char* name = result_name(value)) {
    text = name;
  } else {
    // The spec's spelling for values the runtime does not know.
    text = std::string(value >= 0 ? "XR_UNKNOWN_SUCCESS_" : "XR_UNKNOWN_FAILURE_") + std::to_string(value);
  }
  const std::size_t n = std::min<std::size_t>(text.size(), XR_MAX_RESULT_STRING_SIZE - 1);
  std::memcpy(buffer, text.data(), n);
  buffer[n] = '\0';
  return XR_SUCCESS;
}

XrResult xrStructureTypeToString(XrInstance instance, XrStructureType value, char buffer[XR_MAX_STRUCTURE_NAME_SIZE]) {
  const auto lock = lock_runtime();
  if (find(instance) == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (buffer == nullptr) return XR_ERROR_VALIDATION_FAILURE;
  const char* name = structure_type_name(value);
  const std::string text = name ? name : "XR_UNKNOWN_STRUCTURE_TYPE_" + std::to_string(value);
  const std::size_t n = std::min<std::size_t>(text.size(), XR_MAX_STRUCTURE_NAME_SIZE - 1);
  std::memcpy(buffer, text.data(), n);
  buffer[n] = '\0';
  return XR_SUCCESS;
}

XrResult xrStringToPath(XrInstance instance, const char* path_string, XrPath* path) {
  const auto lock = lock_runtime();
  Instance* inst = find(instance);
  if (inst == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (path_string == nullptr || path == nullptr) return fail(XR_ERROR_VALIDATION_FAILURE, "xrStringToPath", "null argument");
  if (!well_formed_path(path_string))
    return fail(XR_ERROR_PATH_FORMAT_INVALID, "xrStringToPath", std::string("\"") + path_string + "\" is not a well-formed path");
  *path = inst->paths.intern(path_string);
  return XR_SUCCESS;
}

XrResult xrPathToString(XrInstance instance, XrPath path, uint32_t capacity, uint32_t* count, char* buffer) {
  const auto lock = lock_runtime();
  Instance* inst = find(instance);
  if (inst == nullptr) return XR_ERROR_HANDLE_INVALID;
  const std::string* s = inst->paths.lookup(path);
  if (s == nullptr) return fail(XR_ERROR_PATH_INVALID, "xrPathToString", "unknown XrPath " + std::to_string(path));
  const auto n = static_cast<std::uint32_t>(s->size() + 1);  // with the terminating NUL
  return two_call("xrPathToString", capacity, count, buffer == nullptr, n, [&](std::uint32_t i) {
    buffer[i] = i + 1 < n ? (*s)[i] : '\0';
    return XR_SUCCESS;
  });
}

}  // namespace gauss::xr_headless
