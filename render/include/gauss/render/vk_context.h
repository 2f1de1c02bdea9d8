#pragma once
// gauss::vk::Context: Vulkan instance, the chosen physical device, one logical device
// with one queue (graphics + compute + transfer), and the optional validation messenger.
//
// Requirements on a device (checked; an unsuitable device is skipped, or named in the
// error when it was asked for explicitly): Vulkan 1.3 (dynamic rendering and
// synchronization2 are core there), VK_KHR_push_descriptor, a queue family with
// graphics + compute, timestamps on that queue. Lavapipe (Mesa 22.3) meets all of these.
//
// Device choice, in order: ContextCreateInfo::device_override (apps pass their
// --device flag here), else $GAUSS_DEVICE, else the best device by type
// (discrete > integrated > virtual > CPU). An override is a device index (as listed by
// list_devices()) or a case-insensitive substring of VkPhysicalDeviceProperties::deviceName;
// an override that matches no suitable device is an error listing every device.
//
// Validation: VK_LAYER_KHRONOS_validation + a debug messenger when
// ContextCreateInfo::enable_validation is set or $GAUSS_VALIDATION=1 (CTest sets it for
// every test); $GAUSS_VALIDATION=sync adds synchronization validation. Validation is
// then required: a missing layer is an error, never a silent
// run without checks. Every validation ERROR is counted (per context and process-wide)
// and printed to stderr; warnings are printed but not counted.
//
// Threading: the queue is used by one thread at a time (the render thread); the
// submit helpers lock an internal mutex so accidental concurrent submits stay legal.
// A Context must outlive every object created from it (buffers, images, pipelines).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

inline constexpr std::uint32_t kNoMemoryType = ~0u;

struct ContextCreateInfo {
  std::string app_name{"gauss"};
  // Device index or name substring; empty = $GAUSS_DEVICE, else automatic choice.
  std::string device_override{};
  // Validation layers + messenger. Also forced on by $GAUSS_VALIDATION=1
  // ($GAUSS_VALIDATION=0 does not turn off an explicit request here).
  bool enable_validation{false};
  // Adds synchronization validation (missing barriers, hazards) to the validation
  // layer; slower. Also on with $GAUSS_VALIDATION=sync. Implies enable_validation.
  bool synchronization_validation{false};

  // Windowed use (see Swapchain). All three stay empty for offscreen contexts, which
  // then get exactly the instance, device choice and device described above.
  // Instance extensions besides VK_EXT_debug_utils, e.g. glfwGetRequiredInstanceExtensions()
  // (VK_KHR_surface + a platform surface). One the loader lacks is an error naming it.
  std::vector<std::string> instance_extensions{};
  // Device extensions besides VK_KHR_push_descriptor, e.g. VK_KHR_swapchain. A device
  // without one is unsuitable (the reason names it).
  std::vector<std::string> device_extensions{};
  // Called once, right after the instance exists (e.g. glfwCreateWindowSurface). The
  // device must then have a queue family with graphics + compute + timestamps that
  // can also present to this surface (vkGetPhysicalDeviceSurfaceSupportKHR); such a
  // device is chosen and that family becomes queue_family(). The Context owns the
  // surface and destroys it after the device, before the instance. Its error fails
  // create() with the callback's message.
  std::function<Expected<VkSurfaceKHR>(VkInstance)> create_surface{};

  // An OpenXR runtime creates the instance and device itself (XR_KHR_vulkan_enable2:
  // xrCreateVulkanInstanceKHR, xrGetVulkanGraphicsDevice2KHR, xrCreateVulkanDeviceKHR). The
  // Context fills the create infos exactly as it would for vkCreate* and hands them over;
  // it still loads volk from the results and destroys both. Empty = the Context's own calls.
  std::function<Expected<VkInstance>(const VkInstanceCreateInfo&)> create_instance{};
  // The physical device the runtime requires: it must be among the suitable ones (an
  // unsuitable one fails create() with its reason); --device / GAUSS_DEVICE are ignored.
  std::function<Expected<VkPhysicalDevice>(VkInstance)> required_physical_device{};
  std::function<Expected<VkDevice>(VkPhysicalDevice, const VkDeviceCreateInfo&)> create_device{};
};

// One physical device as seen by the instance, for listings and error messages.
struct DeviceInfo {
  std::uint32_t index{0};  // position in vkEnumeratePhysicalDevices order
  std::string name;        // deviceName
  VkPhysicalDeviceType type{VK_PHYSICAL_DEVICE_TYPE_OTHER};
  std::uint32_t api_version{0};
  // Empty when the device meets the requirements above, else why it does not.
  std::string unsuitable_reason;
};

// "discrete", "integrated", "virtual", "cpu", "other".
const char* device_type_name(VkPhysicalDeviceType type) noexcept;

// Value of "--device NAME" or "--device=NAME" in argv, or "" when absent.
// Apps pass the result to ContextCreateInfo::device_override.
std::string device_override_from_args(int argc, const char* const* argv);

// Process-wide count of validation errors reported by every Context so far
// (including destroyed ones): the test helper compares it before/after each test.
std::uint64_t process_validation_error_count() noexcept;

class Context {
 public:
  // Creates instance, device and queue. Errors (all with a readable message): no Vulkan
  // loader/ICD, no physical device, no suitable device, an override that matches
  // nothing, validation requested but the layer is missing, a failed vkCreate*.
  static Expected<std::unique_ptr<Context>> create(const ContextCreateInfo& info = {});

  // Lists the devices a new instance sees (with suitability). Fails only when no
  // Vulkan instance can be created at all.
  static Expected<std::vector<DeviceInfo>> list_devices();

  // Waits for the device to go idle, then destroys everything it created.
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const noexcept { return instance_; }
  VkPhysicalDevice physical_device() const noexcept { return physical_device_; }
  VkDevice device() const noexcept { return device_; }
  VkQueue queue() const noexcept { return queue_; }
  std::uint32_t queue_family() const noexcept { return queue_family_; }
  // The surface made by ContextCreateInfo::create_surface (VK_NULL_HANDLE without one);
  // the queue can present to it. Every swapchain of it must be destroyed before the Context.
  VkSurfaceKHR surface() const noexcept { return surface_; }

  const DeviceInfo& device_info() const noexcept { return device_info_; }
  const std::string& device_name() const noexcept { return device_info_.name; }
  const VkPhysicalDeviceProperties& properties() const noexcept { return properties_; }
  const VkPhysicalDeviceLimits& limits() const noexcept { return properties_.limits; }
  const VkPhysicalDeviceMemoryProperties& memory_properties() const noexcept { return memory_properties_; }
  // Subgroup size of compute shaders (VkPhysicalDeviceSubgroupProperties; lavapipe: 8,
  // 4 with LP_NATIVE_VECTOR_WIDTH=128, 16 with 512) and the operations supported there.
  std::uint32_t subgroup_size() const noexcept { return subgroup_size_; }
  VkSubgroupFeatureFlags subgroup_operations() const noexcept { return subgroup_operations_; }
  // The largest subgroup a compute shader may run with (maxSubgroupSize where the device
  // varies it, else subgroup_size()).
  std::uint32_t max_subgroup_size() const noexcept { return max_subgroup_size_; }
  // The smallest (minSubgroupSize where the device varies it, else subgroup_size()):
  // shared arrays with a row per subgroup are sized for it.
  std::uint32_t min_subgroup_size() const noexcept { return min_subgroup_size_; }
  VkDriverId driver_id() const noexcept { return driver_id_; }
  // The largest single allocation (maxMemoryAllocationSize); a buffer is one allocation.
  VkDeviceSize max_memory_allocation_size() const noexcept { return max_memory_allocation_size_; }
  // Nanoseconds per timestamp tick (VkPhysicalDeviceLimits::timestampPeriod).
  double timestamp_period_ns() const noexcept { return properties_.limits.timestampPeriod; }
  // Bits of a timestamp value that are valid on our queue (64 on lavapipe).
  std::uint32_t timestamp_valid_bits() const noexcept { return timestamp_valid_bits_; }
  // maxStorageBufferRange: the most bytes one storage-buffer binding may cover.
  VkDeviceSize max_storage_buffer_range() const noexcept { return properties_.limits.maxStorageBufferRange; }

  // Features enabled on the device: always dynamicRendering + synchronization2; the
  // rest of a curated list (shaderInt64/Int16, 8/16-bit storage, shaderFloat16, Int8,
  // scalarBlockLayout, hostQueryReset, subgroupSizeControl, computeFullSubgroups,
  // storage-image read/write without format, fragment/vertex stores and atomics)
  // whenever the device supports them. Check here before relying on one.
  const VkPhysicalDeviceFeatures& enabled_features() const noexcept { return enabled_features_; }
  const VkPhysicalDeviceVulkan11Features& enabled_features11() const noexcept { return enabled_features11_; }
  const VkPhysicalDeviceVulkan12Features& enabled_features12() const noexcept { return enabled_features12_; }
  const VkPhysicalDeviceVulkan13Features& enabled_features13() const noexcept { return enabled_features13_; }

  bool validation_enabled() const noexcept { return messenger_ != VK_NULL_HANDLE; }
  // Validation errors reported for this context since creation.
  std::uint64_t validation_error_count() const noexcept;
  // Text of the most recent validation error ("" when none).
  std::string last_validation_error() const;

  // Records through `record` into a fresh primary command buffer, submits it to the
  // queue and waits for it to finish (fence). For uploads, readbacks, tests and
  // anything not frame-paced. Errors name the failed Vulkan call. `record` may call
  // submit_and_wait itself (e.g. a staged upload): that inner submission runs first.
  Status submit_and_wait(const std::function<void(VkCommandBuffer)>& record);

  // Submits an already recorded command buffer; signals `fence` when done (may be null).
  // Waits/signals no semaphores (offscreen use); the XR path adds its own submit.
  Status submit(VkCommandBuffer cmd, VkFence fence);

  // vkDeviceWaitIdle, checked.
  Status wait_idle();

  // Command pool of the queue family (RESET_COMMAND_BUFFER), for CommandBuffer.
  VkCommandPool command_pool() const noexcept { return command_pool_; }

  // A nearest-filter, clamp-to-edge sampler the context owns; used for
  // combined-image-sampler bindings (e.g. reading the mesh depth in compute).
  VkSampler nearest_sampler() const noexcept { return nearest_sampler_; }

  // Index of a memory type allowed by `type_bits` that has all of `required` and, if
  // possible, all of `preferred`; kNoMemoryType when none has `required`.
  std::uint32_t find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required,
                                 VkMemoryPropertyFlags preferred) const noexcept;

  // Names a Vulkan object for validation messages (no-op without validation).
  void set_debug_name(VkObjectType type, std::uint64_t handle, const char* name) const noexcept;

  struct State;  // shared with the debug callback (counts, last message, mutex)

 private:
  Context();

  VkInstance instance_{VK_NULL_HANDLE};
  VkDebugUtilsMessengerEXT messenger_{VK_NULL_HANDLE};
  VkSurfaceKHR surface_{VK_NULL_HANDLE};
  VkPhysicalDevice physical_device_{VK_NULL_HANDLE};
  VkDevice device_{VK_NULL_HANDLE};
  VkQueue queue_{VK_NULL_HANDLE};
  std::uint32_t queue_family_{0};
  VkCommandPool command_pool_{VK_NULL_HANDLE};
  VkSampler nearest_sampler_{VK_NULL_HANDLE};
  DeviceInfo device_info_{};
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceMemoryProperties memory_properties_{};
  std::uint32_t subgroup_size_{0};
  std::uint32_t max_subgroup_size_{0};
  std::uint32_t min_subgroup_size_{0};
  VkSubgroupFeatureFlags subgroup_operations_{0};
  VkDriverId driver_id_{};
  VkDeviceSize max_memory_allocation_size_{0};
  std::uint32_t timestamp_valid_bits_{0};
  VkPhysicalDeviceFeatures enabled_features_{};
  VkPhysicalDeviceVulkan11Features enabled_features11_{};
  VkPhysicalDeviceVulkan12Features enabled_features12_{};
  VkPhysicalDeviceVulkan13Features enabled_features13_{};
  std::unique_ptr<State> state_;
};

}  // namespace gauss::vk
