// Context: instance (+ validation), device choice, logical device, queue, and the
// one-shot submit path. Device selection rules are in vk_context.h.
#include "gauss/render/vk_context.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_commands.h"
#include "vk/debug_messenger.h"
#include "vk/device_select.h"

namespace gauss::vk {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
using detail::kRequiredApi;
using detail::version_string;

// volk keeps process-wide function pointers. They are loaded once from the first
// instance: vkGetInstanceProcAddr hands out loader trampolines that dispatch on the
// handle they are called with, so they serve every later instance and device too
// (every instance enables the same extensions, see create_instance(); a windowed
// context's extra WSI extensions are the exception, so the surface and swapchain code
// fetches those functions from its own instance and device instead of using volk's).
std::mutex g_volk_mutex;
bool g_volk_loaded = false;

Status init_loader() {
  std::lock_guard lock(g_volk_mutex);
  static VkResult init_result = volkInitialize();
  if (init_result != VK_SUCCESS) {
    return Error{"no Vulkan loader found (libvulkan.so.1 could not be loaded): install a Vulkan driver "
                 "(e.g. mesa-vulkan-drivers for the lavapipe CPU device)"};
  }
  return Ok{};
}

void load_instance_functions(VkInstance instance) {
  std::lock_guard lock(g_volk_mutex);
  if (!g_volk_loaded) {
    volkLoadInstance(instance);
    g_volk_loaded = true;
  }
}

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' && std::strcmp(v, "0") != 0;
}

bool has_layer(const char* name) {
  std::uint32_t count = 0;
  if (vkEnumerateInstanceLayerProperties(&count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkLayerProperties> layers(count);
  if (vkEnumerateInstanceLayerProperties(&count, layers.data()) != VK_SUCCESS) return false;
  return std::any_of(layers.begin(), layers.end(), [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

bool has_instance_extension(const char* name) {
  std::uint32_t count = 0;
  if (vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> exts(count);
  if (vkEnumerateInstanceExtensionProperties(nullptr, &count, exts.data()) != VK_SUCCESS) return false;
  return std::any_of(exts.begin(), exts.end(), [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

struct InstanceResult {
  VkInstance instance{VK_NULL_HANDLE};
  bool debug_utils{false};
};

Expected<InstanceResult> create_instance(const std::string& app_name, bool validation, bool sync_validation,
                                         const VkDebugUtilsMessengerCreateInfoEXT* messenger_info,
                                         const std::vector<std::string>& extra_extensions = {},
                                         const ContextCreateInfo* hooks = nullptr) {
  if (auto st = init_loader(); !st) return st.error();
  std::uint32_t loader_version = 0;
  if (vkEnumerateInstanceVersion == nullptr || vkEnumerateInstanceVersion(&loader_version) != VK_SUCCESS ||
      loader_version < kRequiredApi) {
    return Error{"the Vulkan loader supports only Vulkan " + version_string(loader_version) + "; 1.3 is required"};
  }
  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  // Debug utils whenever available, validation or not: object names, and every
  // instance gets the same function pointers (see load_instance_functions()).
  const bool debug_utils = has_instance_extension(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  if (debug_utils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  for (const auto& ext : extra_extensions) {
    if (!has_instance_extension(ext.c_str())) {
      return Error{"the Vulkan loader lacks instance extension " + ext +
                   " (needed to show a window; is the Vulkan driver built with window-system support?)"};
    }
    if (std::none_of(extensions.begin(), extensions.end(), [&](const char* e) { return ext == e; })) {
      extensions.push_back(ext.c_str());
    }
  }
  if (validation) {
    if (!has_layer(kValidationLayer)) {
      return Error{std::string("validation was requested (GAUSS_VALIDATION=1 or enable_validation) but ") +
                   kValidationLayer +
                   " is not installed (Debian: vulkan-validationlayers); set GAUSS_VALIDATION=0 to run without it"};
    }
    if (!debug_utils) {
      return Error{"validation was requested but VK_EXT_debug_utils is unavailable, so errors could not be counted"};
    }
    layers.push_back(kValidationLayer);
  }

  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = app_name.c_str();
  app.applicationVersion = 1;
  app.pEngineName = "GaussAnything";
  app.engineVersion = 1;
  app.apiVersion = kRequiredApi;

  VkInstanceCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  ci.pApplicationInfo = &app;
  ci.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
  ci.ppEnabledLayerNames = layers.data();
  ci.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
  ci.ppEnabledExtensionNames = extensions.data();

  // Chained messenger: also reports problems during vkCreateInstance/vkDestroyInstance.
  VkDebugUtilsMessengerCreateInfoEXT chained{};
  VkValidationFeaturesEXT features{};
  features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
  const VkValidationFeatureEnableEXT sync_enable = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
  if (validation && messenger_info != nullptr) {
    chained = *messenger_info;
    chained.pNext = nullptr;
    if (sync_validation) {
      features.enabledValidationFeatureCount = 1;
      features.pEnabledValidationFeatures = &sync_enable;
      chained.pNext = &features;
    }
    ci.pNext = &chained;
  }

  InstanceResult out;
  if (hooks != nullptr && hooks->create_instance) {
    auto made = hooks->create_instance(ci);
    if (!made) return Error{"the XR runtime could not create the Vulkan instance: " + made.message()};
    out.instance = *made;
  } else if (const VkResult r = vkCreateInstance(&ci, nullptr, &out.instance); r != VK_SUCCESS) {
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER) {
      return Error{"no Vulkan device: no installed Vulkan driver supports Vulkan 1.3 (vkCreateInstance: "
                   "VK_ERROR_INCOMPATIBLE_DRIVER). For the lavapipe CPU device install mesa-vulkan-drivers; "
                   "check VK_ICD_FILENAMES / VK_DRIVER_FILES if set"};
    }
    return result_error(r, "vkCreateInstance", __FILE__, __LINE__);
  }
  out.debug_utils = debug_utils;
  load_instance_functions(out.instance);
  return out;
}

}  // namespace

std::uint64_t process_validation_error_count() noexcept { return detail::process_error_count(); }

Context::Context() : state_(std::make_unique<State>()) {}

Expected<std::vector<DeviceInfo>> Context::list_devices() {
  auto inst = create_instance("gauss-list-devices", false, false, nullptr);
  if (!inst) return inst.error();
  auto candidates = detail::enumerate(inst->instance);
  vkDestroyInstance(inst->instance, nullptr);
  if (!candidates) return candidates.error();
  std::vector<DeviceInfo> out;
  for (auto& c : *candidates) out.push_back(c.info);
  return out;
}

Expected<std::unique_ptr<Context>> Context::create(const ContextCreateInfo& info) {
  std::unique_ptr<Context> ctx(new Context());
  const char* validation_env = std::getenv("GAUSS_VALIDATION");
  const bool env_sync = validation_env && std::strcmp(validation_env, "sync") == 0;
  const bool sync_validation = info.synchronization_validation || env_sync;
  const bool validation = info.enable_validation || sync_validation || env_flag("GAUSS_VALIDATION");

  const VkDebugUtilsMessengerCreateInfoEXT messenger_info = detail::messenger_create_info(ctx->state_.get());
  auto inst =
      create_instance(info.app_name, validation, sync_validation, &messenger_info, info.instance_extensions, &info);
  if (!inst) return inst.error();
  ctx->instance_ = inst->instance;
  if (validation) {
    GAUSS_VK_TRY(vkCreateDebugUtilsMessengerEXT(ctx->instance_, &messenger_info, nullptr, &ctx->messenger_));
  }
  ctx->state_->debug_utils = inst->debug_utils;

  // Windowed contexts: the surface exists before the device choice, which then needs
  // present support on the queue family (and the extra device extensions).
  detail::ExtraRequirements extra;
  extra.device_extensions = info.device_extensions;
  if (info.create_surface) {
    auto surface = info.create_surface(ctx->instance_);
    if (!surface) return Error{"creating the window surface failed: " + surface.error().message};
    ctx->surface_ = *surface;
    extra.surface = ctx->surface_;
    extra.get_surface_support = reinterpret_cast<PFN_vkGetPhysicalDeviceSurfaceSupportKHR>(
        vkGetInstanceProcAddr(ctx->instance_, "vkGetPhysicalDeviceSurfaceSupportKHR"));
    if (extra.get_surface_support == nullptr) {
      return Error{"vkGetPhysicalDeviceSurfaceSupportKHR is unavailable: enable VK_KHR_surface through "
                   "ContextCreateInfo::instance_extensions"};
    }
  }

  auto candidates = detail::enumerate(ctx->instance_, extra);
  if (!candidates) return candidates.error();
  std::string override_value = info.device_override;
  const char* source = "--device";
  if (override_value.empty()) {
    if (const char* env = std::getenv("GAUSS_DEVICE"); env && *env) {
      override_value = env;
      source = "GAUSS_DEVICE";
    }
  }
  Expected<detail::Candidate> chosen = Error{"no device"};
  if (info.required_physical_device) {
    auto required = info.required_physical_device(ctx->instance_);
    if (!required) return Error{"the XR runtime names no Vulkan device: " + required.message()};
    chosen = detail::require_device(*candidates, *required);
  } else {
    chosen = detail::choose_device(*candidates, override_value, source);
  }
  if (!chosen) return chosen.error();
  ctx->physical_device_ = chosen->handle;
  ctx->device_info_ = chosen->info;

  VkPhysicalDeviceDriverProperties driver{};  // core in Vulkan 1.2
  driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
  VkPhysicalDeviceMaintenance3Properties maintenance3{};  // core in Vulkan 1.1
  maintenance3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
  maintenance3.pNext = &driver;
  VkPhysicalDeviceSubgroupSizeControlProperties size_control{};  // core in Vulkan 1.3
  size_control.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_SIZE_CONTROL_PROPERTIES;
  size_control.pNext = &maintenance3;
  VkPhysicalDeviceSubgroupProperties subgroup{};
  subgroup.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
  subgroup.pNext = &size_control;
  VkPhysicalDeviceProperties2 props2{};
  props2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  props2.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(ctx->physical_device_, &props2);
  ctx->properties_ = props2.properties;
  ctx->subgroup_size_ = subgroup.subgroupSize;
  ctx->max_subgroup_size_ = std::max(subgroup.subgroupSize, size_control.maxSubgroupSize);
  ctx->min_subgroup_size_ = size_control.minSubgroupSize > 0 ? std::min(subgroup.subgroupSize, size_control.minSubgroupSize)
                                                             : subgroup.subgroupSize;
  ctx->driver_id_ = driver.driverID;
  ctx->max_memory_allocation_size_ = maintenance3.maxMemoryAllocationSize;
  ctx->subgroup_operations_ = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) ? subgroup.supportedOperations : 0;
  vkGetPhysicalDeviceMemoryProperties(ctx->physical_device_, &ctx->memory_properties_);
  ctx->queue_family_ = detail::pick_queue_family(ctx->physical_device_, &ctx->timestamp_valid_bits_, &extra);

  // Enable the required features plus every supported one of a curated list.
  detail::FeatureChain supported;
  vkGetPhysicalDeviceFeatures2(ctx->physical_device_, &supported.f2);
  detail::FeatureChain enable;
  const VkPhysicalDeviceFeatures& s10 = supported.f2.features;
  VkPhysicalDeviceFeatures& e10 = enable.f2.features;
  e10.shaderInt64 = s10.shaderInt64;
  e10.shaderInt16 = s10.shaderInt16;
  e10.shaderStorageImageReadWithoutFormat = s10.shaderStorageImageReadWithoutFormat;
  e10.shaderStorageImageWriteWithoutFormat = s10.shaderStorageImageWriteWithoutFormat;
  e10.fragmentStoresAndAtomics = s10.fragmentStoresAndAtomics;
  e10.vertexPipelineStoresAndAtomics = s10.vertexPipelineStoresAndAtomics;
  enable.f11.storageBuffer16BitAccess = supported.f11.storageBuffer16BitAccess;
  enable.f11.uniformAndStorageBuffer16BitAccess = supported.f11.uniformAndStorageBuffer16BitAccess;
  enable.f11.storagePushConstant16 = supported.f11.storagePushConstant16;
  enable.f12.storageBuffer8BitAccess = supported.f12.storageBuffer8BitAccess;
  enable.f12.uniformAndStorageBuffer8BitAccess = supported.f12.uniformAndStorageBuffer8BitAccess;
  enable.f12.shaderInt8 = supported.f12.shaderInt8;
  enable.f12.shaderFloat16 = supported.f12.shaderFloat16;
  enable.f12.scalarBlockLayout = supported.f12.scalarBlockLayout;
  enable.f12.hostQueryReset = supported.f12.hostQueryReset;
  enable.f12.shaderSubgroupExtendedTypes = supported.f12.shaderSubgroupExtendedTypes;
  enable.f13.dynamicRendering = VK_TRUE;
  enable.f13.synchronization2 = VK_TRUE;
  enable.f13.subgroupSizeControl = supported.f13.subgroupSizeControl;
  enable.f13.computeFullSubgroups = supported.f13.computeFullSubgroups;
  enable.f13.maintenance4 = supported.f13.maintenance4;

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{};
  qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  qci.queueFamilyIndex = ctx->queue_family_;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  std::vector<const char*> device_extensions = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
  for (const auto& ext : info.device_extensions) {
    if (ext != VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME) device_extensions.push_back(ext.c_str());
  }
  VkDeviceCreateInfo dci{};
  dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  dci.pNext = &enable.f2;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = static_cast<std::uint32_t>(device_extensions.size());
  dci.ppEnabledExtensionNames = device_extensions.data();
  if (info.create_device) {
    auto made = info.create_device(ctx->physical_device_, dci);
    if (!made) return Error{"the XR runtime could not create the Vulkan device: " + made.message()};
    ctx->device_ = *made;
  } else {
    GAUSS_VK_TRY(vkCreateDevice(ctx->physical_device_, &dci, nullptr, &ctx->device_));
  }
  ctx->enabled_features_ = enable.f2.features;
  ctx->enabled_features11_ = enable.f11;
  ctx->enabled_features12_ = enable.f12;
  ctx->enabled_features13_ = enable.f13;
  ctx->enabled_features11_.pNext = nullptr;
  ctx->enabled_features12_.pNext = nullptr;
  ctx->enabled_features13_.pNext = nullptr;
  vkGetDeviceQueue(ctx->device_, ctx->queue_family_, 0, &ctx->queue_);

  VkCommandPoolCreateInfo pci{};
  pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = ctx->queue_family_;
  GAUSS_VK_TRY(vkCreateCommandPool(ctx->device_, &pci, nullptr, &ctx->command_pool_));

  VkSamplerCreateInfo sci{};
  sci.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  sci.magFilter = VK_FILTER_NEAREST;
  sci.minFilter = VK_FILTER_NEAREST;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sci.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sci.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sci.maxLod = 0.0f;
  GAUSS_VK_TRY(vkCreateSampler(ctx->device_, &sci, nullptr, &ctx->nearest_sampler_));
  ctx->set_debug_name(VK_OBJECT_TYPE_SAMPLER, reinterpret_cast<std::uint64_t>(ctx->nearest_sampler_),
                      "context nearest sampler");
  return ctx;
}

Context::~Context() {
  if (device_ != VK_NULL_HANDLE) {
    // Destruction cannot report an error; a lost device is printed, not fatal.
    if (VkResult r = vkDeviceWaitIdle(device_); r != VK_SUCCESS) {
      std::fprintf(stderr, "gauss::vk::Context: vkDeviceWaitIdle failed with %s during destruction\n", result_name(r));
    }
    if (nearest_sampler_) vkDestroySampler(device_, nearest_sampler_, nullptr);
    if (command_pool_) vkDestroyCommandPool(device_, command_pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (instance_ != VK_NULL_HANDLE) {
    if (surface_ != VK_NULL_HANDLE) {
      auto destroy_surface =
          reinterpret_cast<PFN_vkDestroySurfaceKHR>(vkGetInstanceProcAddr(instance_, "vkDestroySurfaceKHR"));
      if (destroy_surface != nullptr) destroy_surface(instance_, surface_, nullptr);
    }
    if (messenger_ != VK_NULL_HANDLE) vkDestroyDebugUtilsMessengerEXT(instance_, messenger_, nullptr);
    vkDestroyInstance(instance_, nullptr);
  }
}

std::uint64_t Context::validation_error_count() const noexcept { return state_->error_count.load(); }

std::string Context::last_validation_error() const {
  std::lock_guard lock(state_->mutex);
  return state_->last_error;
}

Status Context::submit(VkCommandBuffer cmd, VkFence fence) {
  VkCommandBufferSubmitInfo cbi{};
  cbi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
  cbi.commandBuffer = cmd;
  VkSubmitInfo2 si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbi;
  std::lock_guard lock(state_->queue_mutex);
  GAUSS_VK_TRY(vkQueueSubmit2(queue_, 1, &si, fence));
  return Ok{};
}

Status Context::submit_and_wait(const std::function<void(VkCommandBuffer)>& record) {
  // A command buffer and a fence of its own per call: `record` may itself call
  // submit_and_wait (e.g. a staged Buffer::upload); that inner work then runs first.
  auto cb = CommandBuffer::create(*this);
  if (!cb) return cb.error();
  if (auto st = cb->begin(); !st) return st;
  record(cb->handle());
  if (auto st = cb->end(); !st) return st;
  return cb->submit_and_wait();
}

Status Context::wait_idle() {
  GAUSS_VK_TRY(vkDeviceWaitIdle(device_));
  return Ok{};
}

std::uint32_t Context::find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required,
                                        VkMemoryPropertyFlags preferred) const noexcept {
  std::uint32_t fallback = kNoMemoryType;
  for (std::uint32_t i = 0; i < memory_properties_.memoryTypeCount; ++i) {
    if ((type_bits & (1u << i)) == 0) continue;
    const VkMemoryPropertyFlags flags = memory_properties_.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback == kNoMemoryType) fallback = i;
  }
  return fallback;
}

void Context::set_debug_name(VkObjectType type, std::uint64_t handle, const char* name) const noexcept {
  if (!state_->debug_utils || vkSetDebugUtilsObjectNameEXT == nullptr || handle == 0 || name == nullptr) return;
  VkDebugUtilsObjectNameInfoEXT ni{};
  ni.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT;
  ni.objectType = type;
  ni.objectHandle = handle;
  ni.pObjectName = name;
  // Naming is a debugging aid; its failure must not fail the caller.
  (void)vkSetDebugUtilsObjectNameEXT(device_, &ni);
}

}  // namespace gauss::vk
