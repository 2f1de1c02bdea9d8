#include "gauss/xr/xr_session.h"

#include <algorithm>
#include <utility>
#include <vector>

#define XR_USE_GRAPHICS_API_VULKAN
#include <openxr/openxr_platform.h>

#include "gauss/render/vk_commands.h"
#include "gauss/xr/xr_pose.h"
#include "xr_check.h"
#include "xr_instance.h"

namespace gauss::xr {

using detail::result_text;
using detail::xr_error;
using detail::xr_struct;

const char* to_string(SessionPhase phase) {
  switch (phase) {
    case SessionPhase::Idle: return "idle";
    case SessionPhase::Running: return "running";
    case SessionPhase::Stopping: return "stopping";
    case SessionPhase::LossPending: return "loss pending";
    case SessionPhase::Exiting: return "exiting";
  }
  return "?";
}

namespace {

// The renderer's colour targets are RGBA8 with display-referred values (what a PNG of them
// shows). Copied byte for byte into an _SRGB swapchain image the compositor decodes them as
// sRGB, which is what they are; a UNORM image would be read as linear (too bright), so it
// comes second. BGRA would need a swizzle the copy does not do.
constexpr VkFormat kFormatPreference[] = {VK_FORMAT_R8G8B8A8_SRGB, VK_FORMAT_R8G8B8A8_UNORM};

// The status banner: a 64 x 16 image shown 24 x 6 cm, 0.6 m ahead and 12 cm up in view.
constexpr std::uint32_t kBannerWidth = 64, kBannerHeight = 16;

// XR_KHR_vulkan_enable2's entry points (not exported by the loader: asked of the instance).
struct VulkanEnable2 {
  PFN_xrGetVulkanGraphicsRequirements2KHR requirements{nullptr};
  PFN_xrCreateVulkanInstanceKHR create_instance{nullptr};
  PFN_xrGetVulkanGraphicsDevice2KHR device_of{nullptr};
  PFN_xrCreateVulkanDeviceKHR create_device{nullptr};
};

Status load(XrInstance instance, VulkanEnable2& out) {
  const std::pair<const char*, PFN_xrVoidFunction*> entries[] = {
      {"xrGetVulkanGraphicsRequirements2KHR", reinterpret_cast<PFN_xrVoidFunction*>(&out.requirements)},
      {"xrCreateVulkanInstanceKHR", reinterpret_cast<PFN_xrVoidFunction*>(&out.create_instance)},
      {"xrGetVulkanGraphicsDevice2KHR", reinterpret_cast<PFN_xrVoidFunction*>(&out.device_of)},
      {"xrCreateVulkanDeviceKHR", reinterpret_cast<PFN_xrVoidFunction*>(&out.create_device)}};
  for (const auto& [name, slot] : entries)
    if (const XrResult r = xrGetInstanceProcAddr(instance, name, slot); XR_FAILED(r) || *slot == nullptr)
      return Error{std::string("OpenXR: the runtime lacks ") + name + " (" + result_text(instance, r) + ")"};
  return Ok{};
}

const char* state_name(XrSessionState s) {
  switch (s) {
    case XR_SESSION_STATE_IDLE: return "IDLE";
    case XR_SESSION_STATE_READY: return "READY";
    case XR_SESSION_STATE_SYNCHRONIZED: return "SYNCHRONIZED";
    case XR_SESSION_STATE_VISIBLE: return "VISIBLE";
    case XR_SESSION_STATE_FOCUSED: return "FOCUSED";
    case XR_SESSION_STATE_STOPPING: return "STOPPING";
    case XR_SESSION_STATE_LOSS_PENDING: return "LOSS_PENDING";
    case XR_SESSION_STATE_EXITING: return "EXITING";
    default: return "UNKNOWN";
  }
}

XrPose pose_of(const XrPosef& p) {
  XrPose out;
  out.orientation = glm::dquat(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z);
  out.position = glm::dvec3(p.position.x, p.position.y, p.position.z);
  return out;
}

}  // namespace

Expected<std::unique_ptr<HeadsetSession>> HeadsetSession::create(const HeadsetConfig& config) {
  std::unique_ptr<HeadsetSession> s(new HeadsetSession());
  s->config_ = config;

  // Instance: XR_KHR_vulkan_enable2 is required (the renderer is Vulkan only).
  auto opened = detail::open_instance(config.app_name, true);
  if (!opened) return opened.error();
  s->instance_ = opened->instance;
  s->depth_layer_ = opened->depth_layer;
  const XrInstance inst = s->instance_;
  XrResult r = XR_SUCCESS;
  auto props = xr_struct<XrInstanceProperties>(XR_TYPE_INSTANCE_PROPERTIES);
  if (XR_SUCCEEDED(xrGetInstanceProperties(inst, &props))) s->runtime_name_ = props.runtimeName;

  auto sgi = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
  sgi.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
  if (r = xrGetSystem(inst, &sgi, &s->system_); XR_FAILED(r))
    return Error{"OpenXR: no head-mounted display (" + result_text(inst, r) + ")"};
  std::uint32_t views = 0;
  r = xrEnumerateViewConfigurationViews(inst, s->system_, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 0, &views, nullptr);
  if (XR_FAILED(r) || views != 2) return Error{"OpenXR: the headset offers no primary stereo view configuration"};
  std::vector<XrViewConfigurationView> vcv(2, xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW));
  r = xrEnumerateViewConfigurationViews(inst, s->system_, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 2, &views,
                                        vcv.data());
  if (XR_FAILED(r)) return xr_error(inst, "xrEnumerateViewConfigurationViews", r);
  s->width_ = vcv[0].recommendedImageRectWidth;
  s->height_ = vcv[0].recommendedImageRectHeight;
  if (s->width_ == 0 || s->height_ == 0 || vcv[1].recommendedImageRectWidth != s->width_ ||
      vcv[1].recommendedImageRectHeight != s->height_)
    return Error{"OpenXR: the eyes' recommended sizes differ or are empty: " + std::to_string(s->width_) + "x" +
                 std::to_string(s->height_) + " and " + std::to_string(vcv[1].recommendedImageRectWidth) + "x" +
                 std::to_string(vcv[1].recommendedImageRectHeight)};

  // Vulkan through the runtime (its requirements must be asked before the session).
  VulkanEnable2 vk2;
  if (auto st = load(inst, vk2); !st) return st.error();
  auto req = xr_struct<XrGraphicsRequirementsVulkan2KHR>(XR_TYPE_GRAPHICS_REQUIREMENTS_VULKAN2_KHR);
  if (r = vk2.requirements(inst, s->system_, &req); XR_FAILED(r))
    return xr_error(inst, "xrGetVulkanGraphicsRequirements2KHR", r);
  if (XR_MAKE_VERSION(1, 3, 0) < req.minApiVersionSupported)
    return Error{"OpenXR: the runtime needs a newer Vulkan than 1.3"};

  const XrSystemId system = s->system_;
  vk::ContextCreateInfo vci;
  vci.app_name = config.app_name;
  vci.enable_validation = config.enable_validation;
  vci.create_instance = [&](const VkInstanceCreateInfo& info) -> Expected<VkInstance> {
    auto x = xr_struct<XrVulkanInstanceCreateInfoKHR>(XR_TYPE_VULKAN_INSTANCE_CREATE_INFO_KHR);
    x.systemId = system;
    x.pfnGetInstanceProcAddr = vkGetInstanceProcAddr;
    x.vulkanCreateInfo = &info;
    VkInstance out = VK_NULL_HANDLE;
    VkResult vr = VK_SUCCESS;
    if (const XrResult xr = vk2.create_instance(inst, &x, &out, &vr); XR_FAILED(xr))
      return xr_error(inst, "xrCreateVulkanInstanceKHR", xr);
    if (vr != VK_SUCCESS) return Error{"vkCreateInstance (through the runtime) failed: VkResult " + std::to_string(vr)};
    return out;
  };
  vci.required_physical_device = [&](VkInstance vk_instance) -> Expected<VkPhysicalDevice> {
    auto g = xr_struct<XrVulkanGraphicsDeviceGetInfoKHR>(XR_TYPE_VULKAN_GRAPHICS_DEVICE_GET_INFO_KHR);
    g.systemId = system;
    g.vulkanInstance = vk_instance;
    VkPhysicalDevice out = VK_NULL_HANDLE;
    if (const XrResult xr = vk2.device_of(inst, &g, &out); XR_FAILED(xr))
      return xr_error(inst, "xrGetVulkanGraphicsDevice2KHR", xr);
    return out;
  };
  vci.create_device = [&](VkPhysicalDevice physical, const VkDeviceCreateInfo& info) -> Expected<VkDevice> {
    auto x = xr_struct<XrVulkanDeviceCreateInfoKHR>(XR_TYPE_VULKAN_DEVICE_CREATE_INFO_KHR);
    x.systemId = system;
    x.pfnGetInstanceProcAddr = vkGetInstanceProcAddr;
    x.vulkanPhysicalDevice = physical;
    x.vulkanCreateInfo = &info;
    VkDevice out = VK_NULL_HANDLE;
    VkResult vr = VK_SUCCESS;
    if (const XrResult xr = vk2.create_device(inst, &x, &out, &vr); XR_FAILED(xr))
      return xr_error(inst, "xrCreateVulkanDeviceKHR", xr);
    if (vr != VK_SUCCESS) return Error{"vkCreateDevice (through the runtime) failed: VkResult " + std::to_string(vr)};
    return out;
  };
  auto context = vk::Context::create(vci);
  if (!context) return context.error();
  s->context_ = std::move(*context);

  auto binding = xr_struct<XrGraphicsBindingVulkan2KHR>(XR_TYPE_GRAPHICS_BINDING_VULKAN2_KHR);
  binding.instance = s->context_->instance();
  binding.physicalDevice = s->context_->physical_device();
  binding.device = s->context_->device();
  binding.queueFamilyIndex = s->context_->queue_family();
  binding.queueIndex = 0;
  auto sci = xr_struct<XrSessionCreateInfo>(XR_TYPE_SESSION_CREATE_INFO);
  sci.next = &binding;
  sci.systemId = s->system_;
  if (r = xrCreateSession(inst, &sci, &s->session_); XR_FAILED(r)) return xr_error(inst, "xrCreateSession", r);

  const XrReferenceSpaceType type = config.stage_space ? XR_REFERENCE_SPACE_TYPE_STAGE : XR_REFERENCE_SPACE_TYPE_LOCAL;
  std::uint32_t spaces = 0;
  if (r = xrEnumerateReferenceSpaces(s->session_, 0, &spaces, nullptr); XR_FAILED(r))
    return xr_error(inst, "xrEnumerateReferenceSpaces", r);
  std::vector<XrReferenceSpaceType> offered(spaces);
  if (r = xrEnumerateReferenceSpaces(s->session_, spaces, &spaces, offered.data()); XR_FAILED(r))
    return xr_error(inst, "xrEnumerateReferenceSpaces", r);
  if (std::find(offered.begin(), offered.end(), type) == offered.end())
    return Error{std::string("OpenXR: the runtime offers no ") + (config.stage_space ? "STAGE" : "LOCAL") +
                 " reference space"};
  auto rsci = xr_struct<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
  rsci.referenceSpaceType = type;
  rsci.poseInReferenceSpace.orientation.w = 1.0f;
  if (r = xrCreateReferenceSpace(s->session_, &rsci, &s->space_); XR_FAILED(r))
    return xr_error(inst, "xrCreateReferenceSpace", r);
  if (auto st = s->create_swapchains(); !st) return st.error();
  rsci.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_VIEW;  // the banner stays in view
  if (r = xrCreateReferenceSpace(s->session_, &rsci, &s->view_space_); XR_FAILED(r))
    return xr_error(inst, "xrCreateReferenceSpace(VIEW)", r);
  return s;
}

// Fills the banner's image once (amber) and releases it: a layer may show a swapchain's
// last released image on every later frame without acquiring it again.
Status HeadsetSession::prepare_banner() {
  std::uint32_t index = 0;
  auto ai = xr_struct<XrSwapchainImageAcquireInfo>(XR_TYPE_SWAPCHAIN_IMAGE_ACQUIRE_INFO);
  if (const XrResult r = xrAcquireSwapchainImage(banner_, &ai, &index); XR_FAILED(r))
    return xr_error(instance_, "xrAcquireSwapchainImage(banner)", r);
  auto wi = xr_struct<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
  wi.timeout = XR_INFINITE_DURATION;
  if (const XrResult r = xrWaitSwapchainImage(banner_, &wi); XR_FAILED(r))
    return xr_error(instance_, "xrWaitSwapchainImage(banner)", r);
  auto images = swapchain_images(banner_);
  if (!images) return images.error();
  const VkImage image = images->at(index);
  Status filled = context_->submit_and_wait([&](VkCommandBuffer cmd) {
    vk::record_image_barrier(cmd, vk::image_barrier(image, VK_IMAGE_ASPECT_COLOR_BIT,
                                                    VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                                                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                                    VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0,
                                                    VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT));
    VkClearColorValue amber{};
    amber.float32[0] = 1.0f;
    amber.float32[1] = 0.62f;
    amber.float32[2] = 0.0f;
    amber.float32[3] = 1.0f;
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &amber, 1, &range);
    vk::record_image_barrier(cmd, vk::image_barrier(image, VK_IMAGE_ASPECT_COLOR_BIT,
                                                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                                    VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                                                    VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                                    VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT));
  });
  auto ri = xr_struct<XrSwapchainImageReleaseInfo>(XR_TYPE_SWAPCHAIN_IMAGE_RELEASE_INFO);
  if (const XrResult r = xrReleaseSwapchainImage(banner_, &ri); XR_FAILED(r))
    return xr_error(instance_, "xrReleaseSwapchainImage(banner)", r);
  if (!filled) return filled.error();
  banner_ready_ = true;
  return Ok{};
}

Status HeadsetSession::create_swapchains() {
  std::uint32_t count = 0;
  XrResult r = xrEnumerateSwapchainFormats(session_, 0, &count, nullptr);
  if (XR_FAILED(r)) return xr_error(instance_, "xrEnumerateSwapchainFormats", r);
  std::vector<std::int64_t> formats(count);
  if (r = xrEnumerateSwapchainFormats(session_, count, &count, formats.data()); XR_FAILED(r))
    return xr_error(instance_, "xrEnumerateSwapchainFormats", r);
  for (VkFormat f : kFormatPreference)
    if (std::find(formats.begin(), formats.end(), std::int64_t(f)) != formats.end()) {
      format_ = f;
      break;
    }
  if (format_ == VK_FORMAT_UNDEFINED) {
    std::string offered;
    for (std::int64_t f : formats) offered += (offered.empty() ? "" : ", ") + std::to_string(f);
    return Error{"OpenXR: no swapchain format the renderer can copy its RGBA8 images into (it needs VkFormat " +
                 std::to_string(VK_FORMAT_R8G8B8A8_SRGB) + " or " + std::to_string(VK_FORMAT_R8G8B8A8_UNORM) +
                 "; the runtime offers " + (offered.empty() ? std::string("none") : offered) + ")"};
  }
  for (std::size_t eye = 0; eye < 2; ++eye)
    if (auto st = make_swapchain(format_, XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT, width_, height_, swapchains_[eye],
                                 &images_[eye]);
        !st)
      return st;
  // Depth swapchains for the depth layer, when the runtime takes D32_SFLOAT (the renderer's).
  depth_layer_ = depth_layer_ &&
                 std::find(formats.begin(), formats.end(), std::int64_t(VK_FORMAT_D32_SFLOAT)) != formats.end();
  for (std::size_t eye = 0; depth_layer_ && eye < 2; ++eye)
    if (auto st = make_swapchain(VK_FORMAT_D32_SFLOAT, XR_SWAPCHAIN_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, width_,
                                 height_, depth_swapchains_[eye], &depth_images_[eye]);
        !st)
      return st;
  return make_swapchain(format_, XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT, kBannerWidth, kBannerHeight, banner_,
                        nullptr);
}

Status HeadsetSession::make_swapchain(VkFormat format, XrSwapchainUsageFlags usage, std::uint32_t width,
                                      std::uint32_t height, XrSwapchain& out, std::vector<VkImage>* images) {
  auto sc = xr_struct<XrSwapchainCreateInfo>(XR_TYPE_SWAPCHAIN_CREATE_INFO);
  sc.usageFlags = usage | XR_SWAPCHAIN_USAGE_TRANSFER_DST_BIT;  // filled by copies and clears
  sc.format = format;
  sc.sampleCount = 1;
  sc.width = width;
  sc.height = height;
  sc.faceCount = 1;
  sc.arraySize = 1;
  sc.mipCount = 1;
  if (const XrResult r = xrCreateSwapchain(session_, &sc, &out); XR_FAILED(r))
    return xr_error(instance_, "xrCreateSwapchain", r);
  if (images == nullptr) return Ok{};
  auto listed = swapchain_images(out);
  if (!listed) return listed.error();
  *images = std::move(*listed);
  return Ok{};
}

Expected<std::vector<VkImage>> HeadsetSession::swapchain_images(XrSwapchain swapchain) const {
  std::uint32_t n = 0;
  if (const XrResult r = xrEnumerateSwapchainImages(swapchain, 0, &n, nullptr); XR_FAILED(r))
    return xr_error(instance_, "xrEnumerateSwapchainImages", r);
  std::vector<XrSwapchainImageVulkan2KHR> imgs(n, xr_struct<XrSwapchainImageVulkan2KHR>(XR_TYPE_SWAPCHAIN_IMAGE_VULKAN2_KHR));
  if (const XrResult r =
          xrEnumerateSwapchainImages(swapchain, n, &n, reinterpret_cast<XrSwapchainImageBaseHeader*>(imgs.data()));
      XR_FAILED(r))
    return xr_error(instance_, "xrEnumerateSwapchainImages", r);
  std::vector<VkImage> out;
  for (const auto& img : imgs) out.push_back(img.image);
  return out;
}

Expected<SessionPhase> HeadsetSession::poll() {
  for (;;) {
    auto ev = xr_struct<XrEventDataBuffer>(XR_TYPE_EVENT_DATA_BUFFER);
    const XrResult r = xrPollEvent(instance_, &ev);
    if (r == XR_EVENT_UNAVAILABLE) break;
    if (XR_FAILED(r)) return xr_error(instance_, "xrPollEvent", r);
    if (ev.type == XR_TYPE_EVENT_DATA_INSTANCE_LOSS_PENDING) {
      phase_ = SessionPhase::LossPending;
      continue;
    }
    if (ev.type != XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED) continue;
    const XrSessionState state = reinterpret_cast<const XrEventDataSessionStateChanged&>(ev).state;
    states_seen_.push_back(state_name(state));
    switch (state) {
      case XR_SESSION_STATE_READY: {
        auto bi = xr_struct<XrSessionBeginInfo>(XR_TYPE_SESSION_BEGIN_INFO);
        bi.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
        if (const XrResult b = xrBeginSession(session_, &bi); XR_FAILED(b)) return xr_error(instance_, "xrBeginSession", b);
        phase_ = SessionPhase::Running;
        break;
      }
      case XR_SESSION_STATE_STOPPING:
        if (const XrResult e = xrEndSession(session_); XR_FAILED(e)) return xr_error(instance_, "xrEndSession", e);
        phase_ = SessionPhase::Stopping;
        break;
      case XR_SESSION_STATE_LOSS_PENDING: phase_ = SessionPhase::LossPending; break;
      case XR_SESSION_STATE_EXITING: phase_ = SessionPhase::Exiting; break;
      default: break;  // IDLE, SYNCHRONIZED, VISIBLE, FOCUSED: the phase stands
    }
  }
  return phase_;
}

Status HeadsetSession::request_exit() {
  if (phase_ != SessionPhase::Running) {
    phase_ = SessionPhase::Exiting;  // never begun (or already ended): nothing to stop
    return Ok{};
  }
  if (const XrResult r = xrRequestExitSession(session_); XR_FAILED(r))
    return xr_error(instance_, "xrRequestExitSession", r);
  return Ok{};
}

Expected<bool> HeadsetSession::frame(const std::function<Status(const FrameTarget&)>& render) {
  if (phase_ != SessionPhase::Running) return Error{"HeadsetSession::frame: the session is " + std::string(to_string(phase_))};
  auto wait = xr_struct<XrFrameWaitInfo>(XR_TYPE_FRAME_WAIT_INFO);
  auto fs = xr_struct<XrFrameState>(XR_TYPE_FRAME_STATE);
  XrResult r = xrWaitFrame(session_, &wait, &fs);
  if (r == XR_ERROR_SESSION_LOST) {
    phase_ = SessionPhase::LossPending;
    return false;
  }
  if (XR_FAILED(r)) return xr_error(instance_, "xrWaitFrame", r);
  auto begin = xr_struct<XrFrameBeginInfo>(XR_TYPE_FRAME_BEGIN_INFO);
  if (r = xrBeginFrame(session_, &begin); XR_FAILED(r)) {
    if (r == XR_ERROR_SESSION_LOST) {
      phase_ = SessionPhase::LossPending;
      return false;
    }
    return xr_error(instance_, "xrBeginFrame", r);
  }
  if (!fs.shouldRender) {
    if (auto st = end_frame(fs.predictedDisplayTime, false, nullptr); !st) return st.error();
    return false;
  }
  auto locate = xr_struct<XrViewLocateInfo>(XR_TYPE_VIEW_LOCATE_INFO);
  locate.viewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
  locate.displayTime = fs.predictedDisplayTime;
  locate.space = space_;
  auto vstate = xr_struct<XrViewState>(XR_TYPE_VIEW_STATE);
  XrView views[2] = {xr_struct<XrView>(XR_TYPE_VIEW), xr_struct<XrView>(XR_TYPE_VIEW)};
  std::uint32_t located = 0;
  if (r = xrLocateViews(session_, &locate, &vstate, 2, &located, views); XR_FAILED(r))
    return xr_error(instance_, "xrLocateViews", r);
  const XrViewStateFlags needed = XR_VIEW_STATE_ORIENTATION_VALID_BIT | XR_VIEW_STATE_POSITION_VALID_BIT;
  FrameTarget target;
  target.display_time = fs.predictedDisplayTime;
  target.extent = {width_, height_};
  target.format = format_;
  bool usable = located == 2 && (vstate.viewStateFlags & needed) == needed;
  for (std::size_t eye = 0; usable && eye < 2; ++eye) {
    XrFov fov{views[eye].fov.angleLeft, views[eye].fov.angleRight, views[eye].fov.angleUp, views[eye].fov.angleDown};
    target.eyes[eye].pose = views[eye].pose;
    target.eyes[eye].fov = views[eye].fov;
    usable = eye_camera(pose_of(views[eye].pose), fov, width_, height_, scene_from_space_, target.eyes[eye].camera);
    target.eyes[eye].camera.near_plane = config_.near_plane;
    target.eyes[eye].camera.far_plane = config_.far_plane;
  }
  target.near_z = config_.near_plane;
  target.far_z = config_.far_plane;
  if (!usable) {  // no tracking (or a degenerate view): show nothing rather than a wrong pose
    if (auto st = end_frame(fs.predictedDisplayTime, false, nullptr); !st) return st.error();
    return false;
  }
  const auto acquire = [&](XrSwapchain sc, const std::vector<VkImage>& images, VkImage& out) -> Status {
    std::uint32_t index = 0;
    auto ai = xr_struct<XrSwapchainImageAcquireInfo>(XR_TYPE_SWAPCHAIN_IMAGE_ACQUIRE_INFO);
    if (const XrResult a = xrAcquireSwapchainImage(sc, &ai, &index); XR_FAILED(a))
      return xr_error(instance_, "xrAcquireSwapchainImage", a);
    auto wi = xr_struct<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
    wi.timeout = XR_INFINITE_DURATION;
    if (const XrResult w = xrWaitSwapchainImage(sc, &wi); XR_FAILED(w)) return xr_error(instance_, "xrWaitSwapchainImage", w);
    out = images.at(index);
    return Ok{};
  };
  for (std::size_t eye = 0; eye < 2; ++eye) {
    if (auto st = acquire(swapchains_[eye], images_[eye], target.images[eye]); !st) return st.error();
    if (depth_layer_)
      if (auto st = acquire(depth_swapchains_[eye], depth_images_[eye], target.depth_images[eye]); !st)
        return st.error();
  }
  const Status rendered = render(target);
  // Released whatever happened: an acquired image held back would fail every later frame.
  for (std::size_t eye = 0; eye < 2; ++eye)
    for (XrSwapchain sc : {swapchains_[eye], depth_layer_ ? depth_swapchains_[eye] : XrSwapchain{XR_NULL_HANDLE}}) {
      if (sc == XR_NULL_HANDLE) continue;
      auto ri = xr_struct<XrSwapchainImageReleaseInfo>(XR_TYPE_SWAPCHAIN_IMAGE_RELEASE_INFO);
      if (r = xrReleaseSwapchainImage(sc, &ri); XR_FAILED(r)) return xr_error(instance_, "xrReleaseSwapchainImage", r);
    }
  if (!rendered) return rendered.error();
  if (banner_on_ && !banner_ready_)
    if (auto st = prepare_banner(); !st) return st.error();
  if (auto st = end_frame(fs.predictedDisplayTime, true, &target); !st) return st.error();
  return true;
}

Status HeadsetSession::end_frame(XrTime display_time, bool with_layer, const FrameTarget* target) {
  XrCompositionLayerProjectionView pv[2] = {
      xr_struct<XrCompositionLayerProjectionView>(XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW),
      xr_struct<XrCompositionLayerProjectionView>(XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW)};
  XrCompositionLayerDepthInfoKHR depth[2] = {
      xr_struct<XrCompositionLayerDepthInfoKHR>(XR_TYPE_COMPOSITION_LAYER_DEPTH_INFO_KHR),
      xr_struct<XrCompositionLayerDepthInfoKHR>(XR_TYPE_COMPOSITION_LAYER_DEPTH_INFO_KHR)};
  auto layer = xr_struct<XrCompositionLayerProjection>(XR_TYPE_COMPOSITION_LAYER_PROJECTION);
  auto quad = xr_struct<XrCompositionLayerQuad>(XR_TYPE_COMPOSITION_LAYER_QUAD);
  const XrCompositionLayerBaseHeader* layers[2] = {reinterpret_cast<const XrCompositionLayerBaseHeader*>(&layer),
                                                   reinterpret_cast<const XrCompositionLayerBaseHeader*>(&quad)};
  const bool with_banner = with_layer && banner_on_ && banner_ready_;
  if (with_banner) {
    quad.space = view_space_;
    quad.eyeVisibility = XR_EYE_VISIBILITY_BOTH;
    quad.subImage.swapchain = banner_;
    quad.subImage.imageRect.extent = {std::int32_t(kBannerWidth), std::int32_t(kBannerHeight)};
    quad.pose.orientation.w = 1.0f;
    quad.pose.position = {0.0f, 0.12f, -0.6f};
    quad.size = {0.24f, 0.06f};
  }
  if (with_layer) {
    for (std::size_t eye = 0; eye < 2; ++eye) {
      pv[eye].pose = target->eyes[eye].pose;
      pv[eye].fov = target->eyes[eye].fov;
      pv[eye].subImage.swapchain = swapchains_[eye];
      pv[eye].subImage.imageRect.offset = {0, 0};
      pv[eye].subImage.imageRect.extent = {std::int32_t(width_), std::int32_t(height_)};
      pv[eye].subImage.imageArrayIndex = 0;
      if (depth_layer_) {
        depth[eye].subImage.swapchain = depth_swapchains_[eye];
        depth[eye].subImage.imageRect = pv[eye].subImage.imageRect;
        depth[eye].minDepth = 0.0f;
        depth[eye].maxDepth = 1.0f;
        depth[eye].nearZ = float(target->near_z);
        depth[eye].farZ = float(target->far_z);
        pv[eye].next = &depth[eye];
      }
    }
    layer.space = space_;
    layer.viewCount = 2;
    layer.views = pv;
  }
  auto ei = xr_struct<XrFrameEndInfo>(XR_TYPE_FRAME_END_INFO);
  ei.displayTime = display_time;
  ei.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
  ei.layerCount = with_layer ? (with_banner ? 2 : 1) : 0;
  ei.layers = with_layer ? layers : nullptr;
  const XrResult r = xrEndFrame(session_, &ei);
  if (r == XR_ERROR_SESSION_LOST) {
    phase_ = SessionPhase::LossPending;
    return Ok{};
  }
  if (XR_FAILED(r)) return xr_error(instance_, "xrEndFrame", r);
  ++frames_ended_;
  return Ok{};
}

void HeadsetSession::destroy_session() {
  for (XrSwapchain& sc : depth_swapchains_)
    if (sc != XR_NULL_HANDLE) {
      xrDestroySwapchain(sc);
      sc = XR_NULL_HANDLE;
    }
  if (banner_ != XR_NULL_HANDLE) xrDestroySwapchain(banner_);
  banner_ = XR_NULL_HANDLE;
  if (view_space_ != XR_NULL_HANDLE) xrDestroySpace(view_space_);
  view_space_ = XR_NULL_HANDLE;
  for (XrSwapchain& sc : swapchains_)
    if (sc != XR_NULL_HANDLE) {
      xrDestroySwapchain(sc);
      sc = XR_NULL_HANDLE;
    }
  if (space_ != XR_NULL_HANDLE) xrDestroySpace(space_);
  space_ = XR_NULL_HANDLE;
  if (session_ != XR_NULL_HANDLE) xrDestroySession(session_);
  session_ = XR_NULL_HANDLE;
}

HeadsetSession::~HeadsetSession() {
  if (context_) (void)context_->wait_idle();  // the swapchain images may still be read; nothing to do on failure
  destroy_session();
  context_.reset();  // the device and instance the runtime made: ours to destroy
  if (instance_ != XR_NULL_HANDLE) xrDestroyInstance(instance_);
}

}  // namespace gauss::xr
