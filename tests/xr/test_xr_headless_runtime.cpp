// The headless OpenXR runtime (tests/xr/headless_runtime) driven as an app drives a real
// headset: through the system's OpenXR loader only (XR_RUNTIME_JSON points at the
// runtime's manifest), with a Vulkan instance and device made through
// XR_KHR_vulkan_enable2 and validation on. Checks the captured pixels and poses, the
// session lifecycle, scripted loss, action state and the spec's errors for bad calls.
#include <volk.h>

#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>
#include <openxr/openxr_reflection.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gauss/xr/xr_runtime.h"
#include "test_data.h"

namespace {

namespace fsys = std::filesystem;
using nlohmann::json;

std::string xr_name(XrResult r) {
#define GAUSS_TEST_XR_CASE(name, value) \
  case name: return #name;
  switch (r) {
    XR_LIST_ENUM_XrResult(GAUSS_TEST_XR_CASE)
    default: return "XrResult " + std::to_string(r);
  }
#undef GAUSS_TEST_XR_CASE
}

std::string state_name(XrSessionState s) {
#define GAUSS_TEST_XR_CASE(name, value) \
  case name: return #name;
  switch (s) {
    XR_LIST_ENUM_XrSessionState(GAUSS_TEST_XR_CASE)
    default: return "XrSessionState " + std::to_string(s);
  }
#undef GAUSS_TEST_XR_CASE
}

// Results compared by name, so a failure says which code came back.
#define EXPECT_XR(expected, call) EXPECT_EQ(xr_name(call), xr_name(expected)) << #call
#define ASSERT_XR(expected, call) ASSERT_EQ(xr_name(call), xr_name(expected)) << #call

template <class T>
T xr_struct(XrStructureType type) {
  T v{};
  v.type = type;
  return v;
}

std::atomic<int> g_validation_errors{0};

VKAPI_ATTR VkBool32 VKAPI_CALL on_vulkan_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                 VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                                 const VkDebugUtilsMessengerCallbackDataEXT* data, void* /*user*/) {
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    g_validation_errors.fetch_add(1);
    std::fprintf(stderr, "[vulkan validation ERROR] %s\n", data && data->pMessage ? data->pMessage : "?");
  }
  return VK_FALSE;
}

bool vulkan_layer_available(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (const auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

constexpr float kPi = 3.14159265358979f;

// The clear colour that marks frame `frame`, eye `eye`.
std::array<std::uint8_t, 4> marker(std::uint64_t frame, int eye) {
  return {static_cast<std::uint8_t>(10 + 20 * frame), static_cast<std::uint8_t>(eye == 0 ? 60 : 200),
          static_cast<std::uint8_t>(255 - frame), 255};
}

std::vector<std::uint8_t> read_bytes(const fsys::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

json read_json(const fsys::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

class HeadlessXr : public ::testing::Test {
 protected:
  void SetUp() override {
    // Outside CTest the runtime is found through the manifest path compiled in.
    if (std::getenv("XR_RUNTIME_JSON") == nullptr) setenv("XR_RUNTIME_JSON", GAUSS_XR_HEADLESS_MANIFEST, 1);
    unsetenv("GAUSS_XR_HEADLESS_NO_VULKAN");
    unsetenv("GAUSS_XR_HEADLESS_SCRIPT");
    unsetenv("GAUSS_XR_HEADLESS_CAPTURE");
    dir_ = gauss::test::output_dir() / "xr_headless" / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fsys::remove_all(dir_);
    fsys::create_directories(dir_);
    g_validation_errors = 0;
    ASSERT_EQ(volkInitialize(), VK_SUCCESS) << "no Vulkan loader";
  }

  void TearDown() override {
    if (session_ != XR_NULL_HANDLE) xrDestroySession(session_);
    if (instance_ != XR_NULL_HANDLE) xrDestroyInstance(instance_);
    if (device_ != VK_NULL_HANDLE) {
      vkDestroyFence(device_, fence_, nullptr);
      vkDestroyCommandPool(device_, pool_, nullptr);
      vkDestroyDevice(device_, nullptr);
    }
    if (messenger_ != VK_NULL_HANDLE) vkDestroyDebugUtilsMessengerEXT(vk_instance_, messenger_, nullptr);
    if (vk_instance_ != VK_NULL_HANDLE) vkDestroyInstance(vk_instance_, nullptr);
    EXPECT_EQ(g_validation_errors.load(), 0) << "Vulkan validation errors (the runtime's or the test's)";
    if (hid_vulkan_) reload_runtime();
  }

  // The loader keeps the runtime loaded, with the extension list it read, until an
  // instance is destroyed; a test that changed that list (GAUSS_XR_HEADLESS_NO_VULKAN)
  // makes it reload the runtime by creating and destroying a plain instance.
  void reload_runtime() {
    unsetenv("GAUSS_XR_HEADLESS_NO_VULKAN");
    XrInstance plain = XR_NULL_HANDLE;
    std::swap(plain, instance_);
    EXPECT_XR(XR_SUCCESS, try_create_instance({}));
    xrDestroyInstance(instance_);
    instance_ = plain;
  }

  void use_script(const std::string& text) {
    const fsys::path p = dir_ / "script.json";
    std::ofstream(p) << text;
    setenv("GAUSS_XR_HEADLESS_SCRIPT", p.c_str(), 1);
  }

  fsys::path capture_dir() {
    const fsys::path p = dir_ / "capture";
    setenv("GAUSS_XR_HEADLESS_CAPTURE", p.c_str(), 1);
    return p;
  }

  XrResult try_create_instance(std::vector<const char*> extensions) {
    auto ci = xr_struct<XrInstanceCreateInfo>(XR_TYPE_INSTANCE_CREATE_INFO);
    std::strcpy(ci.applicationInfo.applicationName, "gauss-headless-test");
    ci.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
    ci.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
    ci.enabledExtensionNames = extensions.data();
    return xrCreateInstance(&ci, &instance_);
  }

  void create_instance() {
    ASSERT_XR(XR_SUCCESS, try_create_instance({XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME,
                                               XR_KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME}));
    auto gi = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
    gi.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
    ASSERT_XR(XR_SUCCESS, xrGetSystem(instance_, &gi, &system_));
  }

  template <class Fn>
  Fn xr_function(const char* name) {
    PFN_xrVoidFunction fn = nullptr;
    EXPECT_XR(XR_SUCCESS, xrGetInstanceProcAddr(instance_, name, &fn));
    return reinterpret_cast<Fn>(fn);
  }

  // VkInstance and VkDevice through XR_KHR_vulkan_enable2, validation on when installed.
  void create_vulkan() {
    auto get_requirements = xr_function<PFN_xrGetVulkanGraphicsRequirements2KHR>("xrGetVulkanGraphicsRequirements2KHR");
    auto create_vk_instance = xr_function<PFN_xrCreateVulkanInstanceKHR>("xrCreateVulkanInstanceKHR");
    auto get_device = xr_function<PFN_xrGetVulkanGraphicsDevice2KHR>("xrGetVulkanGraphicsDevice2KHR");
    auto create_vk_device = xr_function<PFN_xrCreateVulkanDeviceKHR>("xrCreateVulkanDeviceKHR");
    ASSERT_TRUE(get_requirements && create_vk_instance && get_device && create_vk_device);
    auto req = xr_struct<XrGraphicsRequirementsVulkan2KHR>(XR_TYPE_GRAPHICS_REQUIREMENTS_VULKAN2_KHR);
    ASSERT_XR(XR_SUCCESS, get_requirements(instance_, system_, &req));
    EXPECT_EQ(req.minApiVersionSupported, XR_MAKE_VERSION(1, 0, 0));
    EXPECT_EQ(req.maxApiVersionSupported, XR_MAKE_VERSION(1, 3, 0));

    const char* env = std::getenv("GAUSS_VALIDATION");
    const bool validation = !(env && std::strcmp(env, "0") == 0) && vulkan_layer_available("VK_LAYER_KHRONOS_validation");
    std::vector<const char*> layers;
    std::vector<const char*> extensions;
    if (validation) {
      layers.push_back("VK_LAYER_KHRONOS_validation");
      extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    }
    VkDebugUtilsMessengerCreateInfoEXT messenger{};
    messenger.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
    messenger.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT;
    messenger.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT;
    messenger.pfnUserCallback = on_vulkan_message;
    // GAUSS_VALIDATION=sync adds synchronization validation, as vk::Context does.
    const VkValidationFeatureEnableEXT sync_feature = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
    VkValidationFeaturesEXT features{};
    features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = &sync_feature;
    features.pNext = &messenger;
    const bool sync = env && std::strcmp(env, "sync") == 0;
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "gauss-headless-test";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo vci{};
    vci.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    vci.pNext = !validation ? nullptr : sync ? static_cast<const void*>(&features) : &messenger;
    vci.pApplicationInfo = &app;
    vci.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
    vci.ppEnabledLayerNames = layers.data();
    vci.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
    vci.ppEnabledExtensionNames = extensions.data();
    auto xci = xr_struct<XrVulkanInstanceCreateInfoKHR>(XR_TYPE_VULKAN_INSTANCE_CREATE_INFO_KHR);
    xci.systemId = system_;
    xci.pfnGetInstanceProcAddr = vkGetInstanceProcAddr;
    xci.vulkanCreateInfo = &vci;
    VkResult vr = VK_ERROR_UNKNOWN;
    ASSERT_XR(XR_SUCCESS, create_vk_instance(instance_, &xci, &vk_instance_, &vr));
    ASSERT_EQ(vr, VK_SUCCESS);
    volkLoadInstance(vk_instance_);
    if (validation) {
      ASSERT_EQ(vkCreateDebugUtilsMessengerEXT(vk_instance_, &messenger, nullptr, &messenger_), VK_SUCCESS);
    }

    auto gdi = xr_struct<XrVulkanGraphicsDeviceGetInfoKHR>(XR_TYPE_VULKAN_GRAPHICS_DEVICE_GET_INFO_KHR);
    gdi.systemId = system_;
    gdi.vulkanInstance = vk_instance_;
    ASSERT_XR(XR_SUCCESS, get_device(instance_, &gdi, &physical_device_));
    std::uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, &families, nullptr);
    std::vector<VkQueueFamilyProperties> props(families);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, &families, props.data());
    while (family_ < families && !(props[family_].queueFlags & VK_QUEUE_GRAPHICS_BIT)) ++family_;
    ASSERT_LT(family_, families) << "no graphics queue";
    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{};
    qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qci.queueFamilyIndex = family_;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkDeviceCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    auto xdci = xr_struct<XrVulkanDeviceCreateInfoKHR>(XR_TYPE_VULKAN_DEVICE_CREATE_INFO_KHR);
    xdci.systemId = system_;
    xdci.pfnGetInstanceProcAddr = vkGetInstanceProcAddr;
    xdci.vulkanPhysicalDevice = physical_device_;
    xdci.vulkanCreateInfo = &dci;
    ASSERT_XR(XR_SUCCESS, create_vk_device(instance_, &xdci, &device_, &vr));
    ASSERT_EQ(vr, VK_SUCCESS);
    volkLoadDevice(device_);
    vkGetDeviceQueue(device_, family_, 0, &queue_);
    VkCommandPoolCreateInfo pci{};
    pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pci.queueFamilyIndex = family_;
    ASSERT_EQ(vkCreateCommandPool(device_, &pci, nullptr, &pool_), VK_SUCCESS);
    VkCommandBufferAllocateInfo cai{};
    cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cai.commandPool = pool_;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    ASSERT_EQ(vkAllocateCommandBuffers(device_, &cai, &cmd_), VK_SUCCESS);
    VkFenceCreateInfo fci{};
    fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    ASSERT_EQ(vkCreateFence(device_, &fci, nullptr, &fence_), VK_SUCCESS);
  }

  // Instance, Vulkan, session and a STAGE space; polls to READY and begins the session.
  void start_session() {
    ASSERT_NO_FATAL_FAILURE(create_instance());
    ASSERT_NO_FATAL_FAILURE(create_vulkan());
    auto binding = xr_struct<XrGraphicsBindingVulkan2KHR>(XR_TYPE_GRAPHICS_BINDING_VULKAN2_KHR);
    binding.instance = vk_instance_;
    binding.physicalDevice = physical_device_;
    binding.device = device_;
    binding.queueFamilyIndex = family_;
    binding.queueIndex = 0;
    auto sci = xr_struct<XrSessionCreateInfo>(XR_TYPE_SESSION_CREATE_INFO);
    sci.next = &binding;
    sci.systemId = system_;
    ASSERT_XR(XR_SUCCESS, xrCreateSession(instance_, &sci, &session_));
    auto rci = xr_struct<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
    rci.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_STAGE;
    rci.poseInReferenceSpace.orientation.w = 1.0f;
    ASSERT_XR(XR_SUCCESS, xrCreateReferenceSpace(session_, &rci, &stage_));
    poll();
    ASSERT_EQ(state_, XR_SESSION_STATE_READY);
  }

  void begin_session() {
    auto bi = xr_struct<XrSessionBeginInfo>(XR_TYPE_SESSION_BEGIN_INFO);
    bi.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
    ASSERT_XR(XR_SUCCESS, xrBeginSession(session_, &bi));
  }

  // Drains the event queue, recording session states.
  void poll() {
    auto ev = xr_struct<XrEventDataBuffer>(XR_TYPE_EVENT_DATA_BUFFER);
    while (xrPollEvent(instance_, &ev) == XR_SUCCESS) {
      if (ev.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED) {
        const auto& changed = reinterpret_cast<const XrEventDataSessionStateChanged&>(ev);
        EXPECT_EQ(changed.session, session_);
        state_ = changed.state;
        states_.push_back(state_name(changed.state));
      } else if (ev.type == XR_TYPE_EVENT_DATA_INTERACTION_PROFILE_CHANGED) {
        ++profile_changes_;
      }
      ev = xr_struct<XrEventDataBuffer>(XR_TYPE_EVENT_DATA_BUFFER);
    }
  }

  XrSwapchain make_swapchain(std::int64_t format, std::uint32_t w, std::uint32_t h, XrSwapchainUsageFlags usage,
                             std::vector<VkImage>* images = nullptr) {
    auto ci = xr_struct<XrSwapchainCreateInfo>(XR_TYPE_SWAPCHAIN_CREATE_INFO);
    ci.usageFlags = usage;
    ci.format = format;
    ci.sampleCount = 1;
    ci.width = w;
    ci.height = h;
    ci.faceCount = 1;
    ci.arraySize = 1;
    ci.mipCount = 1;
    XrSwapchain sc = XR_NULL_HANDLE;
    EXPECT_XR(XR_SUCCESS, xrCreateSwapchain(session_, &ci, &sc));
    if (images != nullptr) {
      std::uint32_t n = 0;
      EXPECT_XR(XR_SUCCESS, xrEnumerateSwapchainImages(sc, 0, &n, nullptr));
      std::vector<XrSwapchainImageVulkan2KHR> out(n, xr_struct<XrSwapchainImageVulkan2KHR>(XR_TYPE_SWAPCHAIN_IMAGE_VULKAN2_KHR));
      EXPECT_XR(XR_SUCCESS, xrEnumerateSwapchainImages(sc, n, &n, reinterpret_cast<XrSwapchainImageBaseHeader*>(out.data())));
      for (const auto& i : out) images->push_back(i.image);
    }
    return sc;
  }

  std::uint32_t acquire_and_wait(XrSwapchain sc) {
    std::uint32_t index = 99;
    EXPECT_XR(XR_SUCCESS, xrAcquireSwapchainImage(sc, nullptr, &index));
    auto wi = xr_struct<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
    wi.timeout = XR_INFINITE_DURATION;
    EXPECT_XR(XR_SUCCESS, xrWaitSwapchainImage(sc, &wi));
    return index;
  }

  // Clears a swapchain image (handed over in COLOR_ATTACHMENT_OPTIMAL, returned the same).
  void clear(VkImage image, std::array<std::uint8_t, 4> rgba) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ASSERT_EQ(vkBeginCommandBuffer(cmd_, &begin), VK_SUCCESS);
    VkImageMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    b.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr,
                         0, nullptr, 1, &b);
    VkClearColorValue color{};
    for (int c = 0; c < 4; ++c) color.float32[c] = rgba[c] / 255.0f;  // exact in UNORM8
    vkCmdClearColorImage(cmd_, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &color, 1, &b.subresourceRange);
    b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, 0, 0, nullptr,
                         0, nullptr, 1, &b);
    ASSERT_EQ(vkEndCommandBuffer(cmd_), VK_SUCCESS);
    VkSubmitInfo si{};
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd_;
    ASSERT_EQ(vkQueueSubmit(queue_, 1, &si, fence_), VK_SUCCESS);
    ASSERT_EQ(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX), VK_SUCCESS);
    ASSERT_EQ(vkResetFences(device_, 1, &fence_), VK_SUCCESS);
  }

  XrFrameState wait_and_begin(XrResult expect_wait = XR_SUCCESS) {
    auto fs = xr_struct<XrFrameState>(XR_TYPE_FRAME_STATE);
    EXPECT_XR(expect_wait, xrWaitFrame(session_, nullptr, &fs));
    EXPECT_XR(expect_wait, xrBeginFrame(session_, nullptr));
    return fs;
  }

  void end_empty(XrTime display_time) {
    auto fe = xr_struct<XrFrameEndInfo>(XR_TYPE_FRAME_END_INFO);
    fe.displayTime = display_time;
    fe.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
    EXPECT_XR(XR_SUCCESS, xrEndFrame(session_, &fe));
  }

  std::array<XrView, 2> locate_views(XrTime time, XrSpace space) {
    std::array<XrView, 2> views{xr_struct<XrView>(XR_TYPE_VIEW), xr_struct<XrView>(XR_TYPE_VIEW)};
    auto li = xr_struct<XrViewLocateInfo>(XR_TYPE_VIEW_LOCATE_INFO);
    li.viewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
    li.displayTime = time;
    li.space = space;
    auto vs = xr_struct<XrViewState>(XR_TYPE_VIEW_STATE);
    std::uint32_t n = 0;
    EXPECT_XR(XR_SUCCESS, xrLocateViews(session_, &li, &vs, 2, &n, views.data()));
    EXPECT_EQ(n, 2u);
    EXPECT_EQ(vs.viewStateFlags, XR_VIEW_STATE_ORIENTATION_VALID_BIT | XR_VIEW_STATE_POSITION_VALID_BIT |
                                     XR_VIEW_STATE_ORIENTATION_TRACKED_BIT | XR_VIEW_STATE_POSITION_TRACKED_BIT);
    return views;
  }

  XrPath path(const char* s) {
    XrPath p = XR_NULL_PATH;
    EXPECT_XR(XR_SUCCESS, xrStringToPath(instance_, s, &p));
    return p;
  }

  fsys::path dir_;
  bool hid_vulkan_{false};
  XrInstance instance_{XR_NULL_HANDLE};
  XrSystemId system_{XR_NULL_SYSTEM_ID};
  XrSession session_{XR_NULL_HANDLE};
  XrSpace stage_{XR_NULL_HANDLE};
  XrSessionState state_{XR_SESSION_STATE_UNKNOWN};
  std::vector<std::string> states_;
  int profile_changes_{0};
  VkInstance vk_instance_{VK_NULL_HANDLE};
  VkDebugUtilsMessengerEXT messenger_{VK_NULL_HANDLE};
  VkPhysicalDevice physical_device_{VK_NULL_HANDLE};
  std::uint32_t family_{0};
  VkDevice device_{VK_NULL_HANDLE};
  VkQueue queue_{VK_NULL_HANDLE};
  VkCommandPool pool_{VK_NULL_HANDLE};
  VkCommandBuffer cmd_{VK_NULL_HANDLE};
  VkFence fence_{VK_NULL_HANDLE};
};

TEST_F(HeadlessXr, LoaderFindsTheRuntimeAndItDescribesTheHeadset) {
  use_script(R"({"width": 200, "height": 150, "stage": [5.0, 2.5]})");
  std::uint32_t n = 0;
  ASSERT_XR(XR_SUCCESS, xrEnumerateInstanceExtensionProperties(nullptr, 0, &n, nullptr));
  std::vector<XrExtensionProperties> exts(n, xr_struct<XrExtensionProperties>(XR_TYPE_EXTENSION_PROPERTIES));
  ASSERT_XR(XR_SUCCESS, xrEnumerateInstanceExtensionProperties(nullptr, n, &n, exts.data()));
  std::vector<std::string> names;
  for (const auto& e : exts) names.emplace_back(e.extensionName);
  EXPECT_NE(std::find(names.begin(), names.end(), XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), XR_KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME), names.end());

  ASSERT_NO_FATAL_FAILURE(create_instance());
  auto props = xr_struct<XrInstanceProperties>(XR_TYPE_INSTANCE_PROPERTIES);
  ASSERT_XR(XR_SUCCESS, xrGetInstanceProperties(instance_, &props));
  EXPECT_STREQ(props.runtimeName, "GaussAnything headless");
  auto sys = xr_struct<XrSystemProperties>(XR_TYPE_SYSTEM_PROPERTIES);
  ASSERT_XR(XR_SUCCESS, xrGetSystemProperties(instance_, system_, &sys));
  EXPECT_STREQ(sys.systemName, "headless HMD");
  EXPECT_TRUE(sys.trackingProperties.positionTracking && sys.trackingProperties.orientationTracking);

  std::array<XrViewConfigurationView, 2> views{xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW),
                                               xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW)};
  EXPECT_XR(XR_ERROR_SIZE_INSUFFICIENT, xrEnumerateViewConfigurationViews(instance_, system_,
                                                                          XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 1, &n,
                                                                          views.data()));
  ASSERT_XR(XR_SUCCESS, xrEnumerateViewConfigurationViews(instance_, system_, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 2,
                                                          &n, views.data()));
  EXPECT_EQ(views[1].recommendedImageRectWidth, 200u);
  EXPECT_EQ(views[1].recommendedImageRectHeight, 150u);
  XrEnvironmentBlendMode blend{};
  ASSERT_XR(XR_SUCCESS, xrEnumerateEnvironmentBlendModes(instance_, system_, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 1,
                                                         &n, &blend));
  EXPECT_EQ(blend, XR_ENVIRONMENT_BLEND_MODE_OPAQUE);
  EXPECT_XR(XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED,
            xrEnumerateEnvironmentBlendModes(instance_, system_, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_MONO, 1, &n, &blend));

  // Paths round-trip; malformed ones are refused.
  const XrPath p = path("/user/hand/left/input/trigger/value");
  char text[XR_MAX_PATH_LENGTH];
  ASSERT_XR(XR_SUCCESS, xrPathToString(instance_, p, sizeof text, &n, text));
  EXPECT_STREQ(text, "/user/hand/left/input/trigger/value");
  XrPath bad = XR_NULL_PATH;
  EXPECT_XR(XR_ERROR_PATH_FORMAT_INVALID, xrStringToPath(instance_, "/user//Hand/", &bad));
  EXPECT_XR(XR_ERROR_PATH_INVALID, xrPathToString(instance_, 987654, sizeof text, &n, text));
  char result[XR_MAX_RESULT_STRING_SIZE];
  ASSERT_XR(XR_SUCCESS, xrResultToString(instance_, XR_ERROR_SESSION_LOST, result));
  EXPECT_STREQ(result, "XR_ERROR_SESSION_LOST");

  // Functions the runtime lacks are reported as such, not faked.
  PFN_xrVoidFunction fn = nullptr;
  EXPECT_XR(XR_ERROR_FUNCTION_UNSUPPORTED, xrGetInstanceProcAddr(instance_, "xrCreateHandTrackerEXT", &fn));
  EXPECT_EQ(fn, nullptr);

  // A session needs the graphics requirements queried first (XR_KHR_vulkan_enable2).
  auto binding = xr_struct<XrGraphicsBindingVulkan2KHR>(XR_TYPE_GRAPHICS_BINDING_VULKAN2_KHR);
  auto sci = xr_struct<XrSessionCreateInfo>(XR_TYPE_SESSION_CREATE_INFO);
  sci.next = &binding;
  sci.systemId = system_;
  EXPECT_XR(XR_ERROR_GRAPHICS_REQUIREMENTS_CALL_MISSING, xrCreateSession(instance_, &sci, &session_));
}

TEST_F(HeadlessXr, WithoutVulkanTheExtensionIsMissingAndTheAppSaysSo) {
  setenv("GAUSS_XR_HEADLESS_NO_VULKAN", "1", 1);
  hid_vulkan_ = true;
  std::uint32_t n = 99;
  ASSERT_XR(XR_SUCCESS, xrEnumerateInstanceExtensionProperties(nullptr, 0, &n, nullptr));
  std::vector<XrExtensionProperties> exts(n, xr_struct<XrExtensionProperties>(XR_TYPE_EXTENSION_PROPERTIES));
  ASSERT_XR(XR_SUCCESS, xrEnumerateInstanceExtensionProperties(nullptr, n, &n, exts.data()));
  for (const auto& e : exts) EXPECT_STRNE(e.extensionName, XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME);
  EXPECT_XR(XR_ERROR_EXTENSION_NOT_PRESENT, try_create_instance({XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME}));
  // The project's own OpenXR entry point explains the problem.
  auto rt = gauss::xr::XrRuntime::open("gauss-headless-test");
  ASSERT_FALSE(rt);
  EXPECT_NE(rt.message().find("XR_KHR_vulkan_enable2"), std::string::npos) << rt.message();
}

TEST_F(HeadlessXr, MalformedScriptFailsInstanceCreation) {
  use_script(R"({"width": 64, "keyframes": [{"frame": 0, "right": {"trigger": 1.5}}]})");
  EXPECT_XR(XR_ERROR_INITIALIZATION_FAILED, try_create_instance({XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME}));
  use_script(R"({"widht": 64})");
  EXPECT_XR(XR_ERROR_INITIALIZATION_FAILED, try_create_instance({XR_KHR_VULKAN_ENABLE2_EXTENSION_NAME}));
}

// A whole session: frames rendered with clear colours, two of them captured; the files
// hold exactly those colours and the poses and fovs submitted; the states follow the
// lifecycle up to FOCUSED and, after the scripted exit, down to EXITING.
TEST_F(HeadlessXr, CapturesSubmittedFramesAndFollowsTheLifecycle) {
  const float half = 15.0f * kPi / 180.0f;  // head yaw of 30 degrees from frame 3 on
  use_script(R"({"width": 64, "height": 48, "ipd": 0.07,
    "fov": {"left": -0.8, "right": 0.7, "up": 0.6, "down": -0.65},
    "fov_right": {"left": -0.7, "right": 0.8, "up": 0.6, "down": -0.65},
    "keyframes": [{"frame": 3, "head": {"position": [0.5, 1.7, -0.2], "orientation": [)" +
             std::to_string(std::cos(half)) + ", 0, " + std::to_string(std::sin(half)) + R"(, 0]}}],
    "events": [{"frame": 6, "type": "exit"}],
    "capture": [1, 3]})");
  const fsys::path cap = capture_dir();
  ASSERT_NO_FATAL_FAILURE(start_session());

  std::vector<std::int64_t> formats(16);
  std::uint32_t n = 0;
  ASSERT_XR(XR_SUCCESS, xrEnumerateSwapchainFormats(session_, 16, &n, formats.data()));
  formats.resize(n);
  for (std::int64_t f : {VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_R8G8B8A8_SRGB, VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_D32_SFLOAT})
    EXPECT_NE(std::find(formats.begin(), formats.end(), f), formats.end()) << "format " << f;

  // Left eye RGBA, right eye BGRA (the capture swizzles it to RGBA), and a shared depth.
  std::array<std::vector<VkImage>, 2> images;
  const XrSwapchainUsageFlags color_usage = XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT | XR_SWAPCHAIN_USAGE_TRANSFER_DST_BIT;
  const std::array<XrSwapchain, 2> color{make_swapchain(VK_FORMAT_R8G8B8A8_UNORM, 64, 48, color_usage, &images[0]),
                                         make_swapchain(VK_FORMAT_B8G8R8A8_UNORM, 64, 48, color_usage, &images[1])};
  ASSERT_EQ(images[0].size(), 3u);
  const XrSwapchain depth = make_swapchain(VK_FORMAT_D32_SFLOAT, 64, 48, XR_SWAPCHAIN_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT);
  // The right eye uses a sub-rectangle, so the copy's offset is exercised.
  const std::array<XrRect2Di, 2> rects{XrRect2Di{{0, 0}, {64, 48}}, XrRect2Di{{8, 4}, {48, 40}}};
  ASSERT_NO_FATAL_FAILURE(begin_session());

  std::map<std::uint64_t, std::array<XrView, 2>> located;
  std::map<std::uint64_t, XrTime> display;
  std::uint64_t frame = 0;
  for (;; ++frame) {
    ASSERT_LT(frame, 20u) << "the scripted exit never came";
    poll();
    if (state_ == XR_SESSION_STATE_STOPPING) break;
    const XrFrameState fs = wait_and_begin();
    display[frame] = fs.predictedDisplayTime;
    if (frame > 0) {
      EXPECT_EQ(fs.predictedDisplayTime - display[frame - 1], fs.predictedDisplayPeriod);
    }
    EXPECT_EQ(fs.predictedDisplayPeriod, 13'888'889);
    if (!fs.shouldRender) {
      end_empty(fs.predictedDisplayTime);
      continue;
    }
    const auto views = locate_views(fs.predictedDisplayTime, stage_);
    located[frame] = views;
    std::array<XrCompositionLayerProjectionView, 2> pv{};
    std::array<XrCompositionLayerDepthInfoKHR, 2> di{};
    acquire_and_wait(depth);
    EXPECT_XR(XR_SUCCESS, xrReleaseSwapchainImage(depth, nullptr));
    for (int eye = 0; eye < 2; ++eye) {
      const std::uint32_t index = acquire_and_wait(color[eye]);
      ASSERT_NO_FATAL_FAILURE(clear(images[eye][index], marker(frame, eye)));
      EXPECT_XR(XR_SUCCESS, xrReleaseSwapchainImage(color[eye], nullptr));
      di[eye] = xr_struct<XrCompositionLayerDepthInfoKHR>(XR_TYPE_COMPOSITION_LAYER_DEPTH_INFO_KHR);
      di[eye].subImage = {depth, {{0, 0}, {64, 48}}, 0};
      di[eye].minDepth = 0.0f;
      di[eye].maxDepth = 1.0f;
      di[eye].nearZ = 0.05f;
      di[eye].farZ = 100.0f;
      pv[eye] = xr_struct<XrCompositionLayerProjectionView>(XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW);
      pv[eye].next = &di[eye];
      pv[eye].pose = views[eye].pose;
      pv[eye].fov = views[eye].fov;
      pv[eye].subImage = {color[eye], rects[eye], 0};
    }
    auto layer = xr_struct<XrCompositionLayerProjection>(XR_TYPE_COMPOSITION_LAYER_PROJECTION);
    layer.space = stage_;
    layer.viewCount = 2;
    layer.views = pv.data();
    const auto* base = reinterpret_cast<const XrCompositionLayerBaseHeader*>(&layer);
    auto fe = xr_struct<XrFrameEndInfo>(XR_TYPE_FRAME_END_INFO);
    fe.displayTime = fs.predictedDisplayTime;
    fe.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
    fe.layerCount = 1;
    fe.layers = &base;
    ASSERT_XR(XR_SUCCESS, xrEndFrame(session_, &fe));
  }
  EXPECT_EQ(frame, 7u);  // frames 0..6 waited; the exit came at frame 6
  ASSERT_XR(XR_SUCCESS, xrEndSession(session_));
  poll();
  const std::vector<std::string> expected_states{
      "XR_SESSION_STATE_IDLE",    "XR_SESSION_STATE_READY",        "XR_SESSION_STATE_SYNCHRONIZED",
      "XR_SESSION_STATE_VISIBLE", "XR_SESSION_STATE_FOCUSED",      "XR_SESSION_STATE_VISIBLE",
      "XR_SESSION_STATE_SYNCHRONIZED", "XR_SESSION_STATE_STOPPING", "XR_SESSION_STATE_IDLE",
      "XR_SESSION_STATE_EXITING"};
  EXPECT_EQ(states_, expected_states);
  // Frames 1..5 were rendered (frame 0 was SYNCHRONIZED, frame 6 already stopping).
  EXPECT_EQ(located.size(), 5u);

  // The eyes follow the script: ipd/2 along the head's x axis, per-eye fov.
  const XrView& l3 = located.at(3)[0];
  EXPECT_NEAR(l3.pose.position.x, 0.5f - 0.035f * std::cos(2 * half), 1e-5);
  EXPECT_NEAR(l3.pose.position.y, 1.7f, 1e-5);
  EXPECT_NEAR(l3.pose.position.z, -0.2f + 0.035f * std::sin(2 * half), 1e-5);
  EXPECT_NEAR(located.at(1)[1].pose.position.x, 0.035f, 1e-6);
  EXPECT_NEAR(located.at(1)[1].pose.position.y, 1.6f, 1e-6);
  EXPECT_FLOAT_EQ(located.at(1)[0].fov.angleLeft, -0.8f);
  EXPECT_FLOAT_EQ(located.at(1)[1].fov.angleLeft, -0.7f);

  for (std::uint64_t f : {1u, 3u}) {
    char stem[32];
    std::snprintf(stem, sizeof stem, "frame-%06llu", static_cast<unsigned long long>(f));
    const fsys::path meta_path = cap / (std::string(stem) + ".json");
    ASSERT_TRUE(fsys::exists(meta_path)) << meta_path;
    const json meta = read_json(meta_path);
    EXPECT_EQ(meta["frame"], f);
    EXPECT_EQ(meta["predicted_display_time"].get<XrTime>(), display.at(f));
    EXPECT_EQ(meta["width"], 64);
    EXPECT_EQ(meta["height"], 48);
    EXPECT_EQ(meta["format"], "VK_FORMAT_R8G8B8A8_UNORM");
    EXPECT_EQ(meta["space"], "XR_REFERENCE_SPACE_TYPE_STAGE");
    for (int eye = 0; eye < 2; ++eye) {
      const json& v = meta["views"][eye];
      const XrView& want = located.at(f)[eye];
      const json& pos = v["pose"]["position"];
      const json& ori = v["pose"]["orientation"];
      EXPECT_EQ(pos[0].get<float>(), want.pose.position.x);
      EXPECT_EQ(pos[1].get<float>(), want.pose.position.y);
      EXPECT_EQ(pos[2].get<float>(), want.pose.position.z);
      EXPECT_EQ(ori[0].get<float>(), want.pose.orientation.w);
      EXPECT_EQ(ori[1].get<float>(), want.pose.orientation.x);
      EXPECT_EQ(ori[2].get<float>(), want.pose.orientation.y);
      EXPECT_EQ(ori[3].get<float>(), want.pose.orientation.z);
      EXPECT_EQ(v["fov"]["left"].get<float>(), want.fov.angleLeft);
      EXPECT_EQ(v["fov"]["down"].get<float>(), want.fov.angleDown);
      EXPECT_EQ(v["width"], rects[eye].extent.width);
      EXPECT_EQ(v["depth"]["far_z"].get<float>(), 100.0f);
      const auto bytes = read_bytes(cap / v["file"].get<std::string>());
      const auto rgba = marker(f, eye);
      ASSERT_EQ(bytes.size(), std::size_t(rects[eye].extent.width) * rects[eye].extent.height * 4) << v["file"];
      std::size_t wrong = 0;
      for (std::size_t i = 0; i < bytes.size(); ++i) wrong += bytes[i] != rgba[i % 4];
      EXPECT_EQ(wrong, 0u) << v["file"] << " differs from the clear colour";
    }
  }
  EXPECT_FALSE(fsys::exists(cap / "frame-000002.json")) << "frame 2 was not in the capture list";

  ASSERT_XR(XR_SUCCESS, xrDestroySession(session_));
  session_ = XR_NULL_HANDLE;
  const json summary = read_json(cap / "session.json");
  EXPECT_EQ(summary["states"].get<std::vector<std::string>>(), expected_states);
  EXPECT_EQ(summary["frame_count"], 7);
  EXPECT_EQ(summary["captured_frames"], json::array({1, 3}));
}

TEST_F(HeadlessXr, ScriptedLossEndsTheSession) {
  use_script(R"({"events": [{"frame": 3, "type": "loss"}]})");
  ASSERT_NO_FATAL_FAILURE(start_session());
  ASSERT_NO_FATAL_FAILURE(begin_session());
  for (int frame = 0; frame < 3; ++frame) {
    const XrFrameState fs = wait_and_begin();
    end_empty(fs.predictedDisplayTime);
  }
  // The loss is announced: calls still work but say so until the app has seen the event.
  auto fs = xr_struct<XrFrameState>(XR_TYPE_FRAME_STATE);
  EXPECT_XR(XR_SESSION_LOSS_PENDING, xrWaitFrame(session_, nullptr, &fs));
  EXPECT_XR(XR_SESSION_LOSS_PENDING, xrBeginFrame(session_, nullptr));
  poll();
  EXPECT_EQ(state_, XR_SESSION_STATE_LOSS_PENDING);
  EXPECT_XR(XR_ERROR_SESSION_LOST, xrWaitFrame(session_, nullptr, &fs));
  EXPECT_XR(XR_ERROR_SESSION_LOST, xrEndSession(session_));
  EXPECT_XR(XR_SUCCESS, xrDestroySession(session_));
  session_ = XR_NULL_HANDLE;
}

// Actions follow the scripted right controller: a trigger pull read as a float and as a
// click, the thumbstick, and the aim pose through an action space.
TEST_F(HeadlessXr, ActionsFollowTheScriptedController) {
  use_script(R"({"keyframes": [
    {"frame": 0, "right": {"aim": {"position": [0.3, 1.2, -0.4], "orientation": [1, 0, 0, 0]}}},
    {"frame": 4, "right": {"trigger": 0.3}},
    {"frame": 6, "right": {"trigger": 0.8, "thumbstick": [0.5, -0.25],
                           "aim": {"position": [0.1, 1.3, -0.5], "orientation": [0, 0, 1, 0]}}},
    {"frame": 8, "right": {"trigger": 0.0}}]})");
  ASSERT_NO_FATAL_FAILURE(start_session());
  const XrPath left = path("/user/hand/left");
  const XrPath right = path("/user/hand/right");
  auto sci = xr_struct<XrActionSetCreateInfo>(XR_TYPE_ACTION_SET_CREATE_INFO);
  std::strcpy(sci.actionSetName, "gameplay");
  std::strcpy(sci.localizedActionSetName, "Gameplay");
  XrActionSet set = XR_NULL_HANDLE;
  ASSERT_XR(XR_SUCCESS, xrCreateActionSet(instance_, &sci, &set));
  auto make_action = [&](const char* name, XrActionType type) {
    auto aci = xr_struct<XrActionCreateInfo>(XR_TYPE_ACTION_CREATE_INFO);
    std::strcpy(aci.actionName, name);
    std::strcpy(aci.localizedActionName, name);
    aci.actionType = type;
    const XrPath hands[] = {left, right};
    aci.countSubactionPaths = 2;
    aci.subactionPaths = hands;
    XrAction a = XR_NULL_HANDLE;
    EXPECT_XR(XR_SUCCESS, xrCreateAction(set, &aci, &a));
    return a;
  };
  const XrAction trigger = make_action("trigger_value", XR_ACTION_TYPE_FLOAT_INPUT);
  const XrAction select = make_action("select", XR_ACTION_TYPE_BOOLEAN_INPUT);
  const XrAction stick = make_action("move", XR_ACTION_TYPE_VECTOR2F_INPUT);
  const XrAction aim = make_action("aim", XR_ACTION_TYPE_POSE_INPUT);
  const XrActionSuggestedBinding touch[] = {
      {trigger, path("/user/hand/right/input/trigger/value")},
      {select, path("/user/hand/right/input/trigger/click")},
      {stick, path("/user/hand/right/input/thumbstick")},
      {aim, path("/user/hand/right/input/aim/pose")},
      {aim, path("/user/hand/left/input/aim/pose")},
  };
  auto sb = xr_struct<XrInteractionProfileSuggestedBinding>(XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING);
  sb.interactionProfile = path("/interaction_profiles/oculus/touch_controller");
  sb.countSuggestedBindings = static_cast<std::uint32_t>(std::size(touch));
  sb.suggestedBindings = touch;
  ASSERT_XR(XR_SUCCESS, xrSuggestInteractionProfileBindings(instance_, &sb));
  const XrActionSuggestedBinding wrong[] = {{stick, path("/user/hand/right/input/select/click")}};
  auto sb_wrong = sb;
  sb_wrong.interactionProfile = path("/interaction_profiles/khr/simple_controller");
  sb_wrong.countSuggestedBindings = 1;
  sb_wrong.suggestedBindings = wrong;
  EXPECT_XR(XR_ERROR_PATH_UNSUPPORTED, xrSuggestInteractionProfileBindings(instance_, &sb_wrong));
  auto attach = xr_struct<XrSessionActionSetsAttachInfo>(XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO);
  attach.countActionSets = 1;
  attach.actionSets = &set;
  ASSERT_XR(XR_SUCCESS, xrAttachSessionActionSets(session_, &attach));
  EXPECT_XR(XR_ERROR_ACTIONSETS_ALREADY_ATTACHED, xrSuggestInteractionProfileBindings(instance_, &sb));
  auto profile = xr_struct<XrInteractionProfileState>(XR_TYPE_INTERACTION_PROFILE_STATE);
  ASSERT_XR(XR_SUCCESS, xrGetCurrentInteractionProfile(session_, right, &profile));
  EXPECT_EQ(profile.interactionProfile, sb.interactionProfile);
  auto asci = xr_struct<XrActionSpaceCreateInfo>(XR_TYPE_ACTION_SPACE_CREATE_INFO);
  asci.action = aim;
  asci.subactionPath = right;
  asci.poseInActionSpace.orientation.w = 1.0f;
  XrSpace aim_space = XR_NULL_HANDLE;
  ASSERT_XR(XR_SUCCESS, xrCreateActionSpace(session_, &asci, &aim_space));
  ASSERT_NO_FATAL_FAILURE(begin_session());

  auto get_info = xr_struct<XrActionStateGetInfo>(XR_TYPE_ACTION_STATE_GET_INFO);
  std::map<int, XrTime> display;
  for (int frame = 0; frame < 10; ++frame) {
    poll();
    const XrFrameState fs = wait_and_begin();
    display[frame] = fs.predictedDisplayTime;
    const XrActiveActionSet active{set, XR_NULL_PATH};
    auto sync = xr_struct<XrActionsSyncInfo>(XR_TYPE_ACTIONS_SYNC_INFO);
    sync.countActiveActionSets = 1;
    sync.activeActionSets = &active;
    // FOCUSED from frame 2 on (SYNCHRONIZED at 0, VISIBLE at 1).
    const bool focused = frame >= 2;
    EXPECT_XR(focused ? XR_SUCCESS : XR_SESSION_NOT_FOCUSED, xrSyncActions(session_, &sync)) << "frame " << frame;
    auto value = xr_struct<XrActionStateFloat>(XR_TYPE_ACTION_STATE_FLOAT);
    get_info.action = trigger;
    get_info.subactionPath = XR_NULL_PATH;
    ASSERT_XR(XR_SUCCESS, xrGetActionStateFloat(session_, &get_info, &value));
    auto click = xr_struct<XrActionStateBoolean>(XR_TYPE_ACTION_STATE_BOOLEAN);
    get_info.action = select;
    get_info.subactionPath = right;
    ASSERT_XR(XR_SUCCESS, xrGetActionStateBoolean(session_, &get_info, &click));
    auto move = xr_struct<XrActionStateVector2f>(XR_TYPE_ACTION_STATE_VECTOR2F);
    get_info.action = stick;
    ASSERT_XR(XR_SUCCESS, xrGetActionStateVector2f(session_, &get_info, &move));
    auto loc = xr_struct<XrSpaceLocation>(XR_TYPE_SPACE_LOCATION);
    ASSERT_XR(XR_SUCCESS, xrLocateSpace(aim_space, stage_, fs.predictedDisplayTime, &loc));
    SCOPED_TRACE("frame " + std::to_string(frame));
    EXPECT_EQ(bool(value.isActive), focused);
    EXPECT_EQ(bool(click.isActive), focused);
    if (!focused) {
      EXPECT_EQ(loc.locationFlags, 0u);
    } else {
      const float want = frame >= 8 ? 0.0f : frame >= 6 ? 0.8f : frame >= 4 ? 0.3f : 0.0f;
      EXPECT_EQ(value.currentState, want);
      const bool value_changed = frame == 4 || frame == 6 || frame == 8;
      EXPECT_EQ(bool(value.changedSinceLastSync), value_changed);
      const int value_since = frame >= 8 ? 8 : frame >= 6 ? 6 : frame >= 4 ? 4 : 2;  // 2: became active
      EXPECT_EQ(value.lastChangeTime, display[value_since]);
      EXPECT_EQ(bool(click.currentState), frame == 6 || frame == 7);
      EXPECT_EQ(bool(click.changedSinceLastSync), frame == 6 || frame == 8);
      EXPECT_EQ(move.currentState.x, frame >= 6 ? 0.5f : 0.0f);
      EXPECT_EQ(move.currentState.y, frame >= 6 ? -0.25f : 0.0f);
      EXPECT_EQ(loc.locationFlags, XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT |
                                       XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT);
      EXPECT_NEAR(loc.pose.position.x, frame >= 6 ? 0.1f : 0.3f, 1e-6);
      EXPECT_NEAR(loc.pose.position.z, frame >= 6 ? -0.5f : -0.4f, 1e-6);
      EXPECT_NEAR(std::abs(loc.pose.orientation.y), frame >= 6 ? 1.0f : 0.0f, 1e-6);  // yawed 180 degrees
    }
    end_empty(fs.predictedDisplayTime);
  }
  EXPECT_EQ(profile_changes_, 1);
  auto bsi = xr_struct<XrBoundSourcesForActionEnumerateInfo>(XR_TYPE_BOUND_SOURCES_FOR_ACTION_ENUMERATE_INFO);
  bsi.action = aim;
  std::array<XrPath, 4> sources{};
  std::uint32_t n = 0;
  ASSERT_XR(XR_SUCCESS, xrEnumerateBoundSourcesForAction(session_, &bsi, 4, &n, sources.data()));
  EXPECT_EQ(n, 2u);
  auto lni = xr_struct<XrInputSourceLocalizedNameGetInfo>(XR_TYPE_INPUT_SOURCE_LOCALIZED_NAME_GET_INFO);
  lni.sourcePath = sources[0];
  lni.whichComponents = XR_INPUT_SOURCE_LOCALIZED_NAME_USER_PATH_BIT | XR_INPUT_SOURCE_LOCALIZED_NAME_COMPONENT_BIT;
  char name[64];
  ASSERT_XR(XR_SUCCESS, xrGetInputSourceLocalizedName(session_, &lni, sizeof name, &n, name));
  EXPECT_STREQ(name, "Right Hand Aim Pose");
  get_info.action = trigger;
  auto wrong_type = xr_struct<XrActionStateBoolean>(XR_TYPE_ACTION_STATE_BOOLEAN);
  EXPECT_XR(XR_ERROR_ACTION_TYPE_MISMATCH, xrGetActionStateBoolean(session_, &get_info, &wrong_type));
}

// Calls out of order get the spec's error codes (and change nothing).
TEST_F(HeadlessXr, BadCallsGetTheSpecsErrors) {
  ASSERT_NO_FATAL_FAILURE(start_session());
  std::vector<VkImage> images;
  const XrSwapchain sc = make_swapchain(VK_FORMAT_R8G8B8A8_SRGB, 32, 32, XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT, &images);
  const XrSwapchain never_released = make_swapchain(VK_FORMAT_R8G8B8A8_UNORM, 32, 32, XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT);
  auto fs = xr_struct<XrFrameState>(XR_TYPE_FRAME_STATE);
  EXPECT_XR(XR_ERROR_SESSION_NOT_RUNNING, xrWaitFrame(session_, nullptr, &fs));
  ASSERT_NO_FATAL_FAILURE(begin_session());
  auto bi = xr_struct<XrSessionBeginInfo>(XR_TYPE_SESSION_BEGIN_INFO);
  bi.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
  EXPECT_XR(XR_ERROR_SESSION_RUNNING, xrBeginSession(session_, &bi));
  EXPECT_XR(XR_ERROR_CALL_ORDER_INVALID, xrBeginFrame(session_, nullptr));  // no xrWaitFrame
  auto fe = xr_struct<XrFrameEndInfo>(XR_TYPE_FRAME_END_INFO);
  fe.displayTime = 1;
  fe.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
  EXPECT_XR(XR_ERROR_CALL_ORDER_INVALID, xrEndFrame(session_, &fe));  // no xrBeginFrame

  // Swapchain image order: release / wait need an acquired image; at most 3 held.
  EXPECT_XR(XR_ERROR_CALL_ORDER_INVALID, xrReleaseSwapchainImage(sc, nullptr));
  auto wi = xr_struct<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
  wi.timeout = XR_INFINITE_DURATION;
  EXPECT_XR(XR_ERROR_CALL_ORDER_INVALID, xrWaitSwapchainImage(sc, &wi));
  std::uint32_t index = 0;
  for (std::uint32_t i = 0; i < 3; ++i) {
    EXPECT_XR(XR_SUCCESS, xrAcquireSwapchainImage(sc, nullptr, &index));
    EXPECT_EQ(index, i);
  }
  EXPECT_XR(XR_ERROR_CALL_ORDER_INVALID, xrAcquireSwapchainImage(sc, nullptr, &index));
  EXPECT_XR(XR_SUCCESS, xrWaitSwapchainImage(sc, &wi));
  EXPECT_XR(XR_ERROR_CALL_ORDER_INVALID, xrWaitSwapchainImage(sc, &wi));  // release the waited one first
  EXPECT_XR(XR_SUCCESS, xrReleaseSwapchainImage(sc, nullptr));

  const XrFrameState state = wait_and_begin();
  EXPECT_XR(XR_FRAME_DISCARDED, [&] {
    EXPECT_XR(XR_SUCCESS, xrWaitFrame(session_, nullptr, &fs));
    return xrBeginFrame(session_, nullptr);
  }());
  std::array<XrCompositionLayerProjectionView, 2> pv{};
  for (auto& v : pv) {
    v = xr_struct<XrCompositionLayerProjectionView>(XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW);
    v.pose.orientation.w = 1.0f;
    v.fov = {-0.5f, 0.5f, 0.5f, -0.5f};
    v.subImage = {never_released, {{0, 0}, {32, 32}}, 0};
  }
  auto layer = xr_struct<XrCompositionLayerProjection>(XR_TYPE_COMPOSITION_LAYER_PROJECTION);
  layer.space = stage_;
  layer.viewCount = 2;
  layer.views = pv.data();
  const auto* base = reinterpret_cast<const XrCompositionLayerBaseHeader*>(&layer);
  fe.displayTime = state.predictedDisplayTime;
  fe.layerCount = 1;
  fe.layers = &base;
  EXPECT_XR(XR_ERROR_LAYER_INVALID, xrEndFrame(session_, &fe));
  for (auto& v : pv) v.subImage = {sc, {{16, 0}, {32, 32}}, 0};
  EXPECT_XR(XR_ERROR_SWAPCHAIN_RECT_INVALID, xrEndFrame(session_, &fe));
  pv[1].pose.orientation.w = 2.0f;
  for (auto& v : pv) v.subImage.imageRect = {{0, 0}, {32, 32}};
  EXPECT_XR(XR_ERROR_POSE_INVALID, xrEndFrame(session_, &fe));
  pv[1].pose.orientation.w = 1.0f;
  EXPECT_XR(XR_SUCCESS, xrEndFrame(session_, &fe));

  EXPECT_XR(XR_ERROR_SESSION_NOT_STOPPING, xrEndSession(session_));
  XrSpace view = XR_NULL_HANDLE;
  auto rci = xr_struct<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
  rci.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_VIEW;
  rci.poseInReferenceSpace.orientation.w = 1.0f;
  ASSERT_XR(XR_SUCCESS, xrCreateReferenceSpace(session_, &rci, &view));
  ASSERT_XR(XR_SUCCESS, xrDestroySpace(view));
  auto loc = xr_struct<XrSpaceLocation>(XR_TYPE_SPACE_LOCATION);
  EXPECT_XR(XR_ERROR_HANDLE_INVALID, xrLocateSpace(view, stage_, state.predictedDisplayTime, &loc));

  // The app asks to exit: down to STOPPING, then IDLE and EXITING after xrEndSession.
  ASSERT_XR(XR_SUCCESS, xrRequestExitSession(session_));
  poll();
  EXPECT_EQ(state_, XR_SESSION_STATE_STOPPING);
  ASSERT_XR(XR_SUCCESS, xrEndSession(session_));
  poll();
  EXPECT_EQ(state_, XR_SESSION_STATE_EXITING);
  EXPECT_XR(XR_ERROR_SESSION_NOT_RUNNING, xrWaitFrame(session_, nullptr, &fs));
}

}  // namespace
