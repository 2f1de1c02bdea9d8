// Session creation with a Vulkan binding, begin/end/exit, and destruction (which also
// writes the capture folder's session.json).
#include "entry_points.h"
#include "readback.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {

XrResult xrCreateSession(XrInstance instance, const XrSessionCreateInfo* create_info, XrSession* session) {
  const char* fn = "xrCreateSession";
  const auto lock = lock_runtime();
  Instance* inst = find(instance);
  if (inst == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(create_info, XR_TYPE_SESSION_CREATE_INFO) || session == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrSessionCreateInfo and session non-null");
  if (create_info->systemId != kSystemId) return XR_ERROR_SYSTEM_INVALID;
  if (create_info->createFlags != 0) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createFlags must be 0");
  const auto* binding = static_cast<const XrGraphicsBindingVulkan2KHR*>(
      find_in_chain(create_info->next, XR_TYPE_GRAPHICS_BINDING_VULKAN2_KHR));
  if (!inst->vulkan_enable2 || binding == nullptr)
    return fail(XR_ERROR_GRAPHICS_DEVICE_INVALID, fn,
                "a session needs XR_KHR_vulkan_enable2 and an XrGraphicsBindingVulkan2KHR in createInfo->next");
  if (!inst->graphics_requirements_queried)
    return fail(XR_ERROR_GRAPHICS_REQUIREMENTS_CALL_MISSING, fn, "call xrGetVulkanGraphicsRequirements2KHR first");
  if (inst->session_id != 0) return fail(XR_ERROR_LIMIT_REACHED, fn, "this runtime runs one session per instance");
  if (binding->instance == VK_NULL_HANDLE || binding->device == VK_NULL_HANDLE)
    return fail(XR_ERROR_GRAPHICS_DEVICE_INVALID, fn, "the binding's VkInstance and VkDevice must be non-null");
  auto pd = inst->vk_physical_devices.find(binding->physicalDevice);
  if (pd == inst->vk_physical_devices.end() || pd->second != binding->instance)
    return fail(XR_ERROR_GRAPHICS_DEVICE_INVALID, fn,
                "physicalDevice is not what xrGetVulkanGraphicsDevice2KHR returned for this VkInstance");
  if (auto dev = inst->vk_device_queues.find(binding->device); dev != inst->vk_device_queues.end()) {
    auto family = dev->second.find(binding->queueFamilyIndex);
    if (family == dev->second.end() || binding->queueIndex >= family->second)
      return fail(XR_ERROR_VALIDATION_FAILURE, fn, "the binding's queue was not created with the VkDevice");
  }
  PFN_vkGetInstanceProcAddr gipa = inst->vk_instances.at(binding->instance);
  auto vk = open_vulkan_device(gipa, *binding);
  if (!vk) return fail(XR_ERROR_RUNTIME_FAILURE, fn, vk.message());

  auto s = std::make_unique<Session>();
  s->instance_id = to_id(instance);
  s->vk = std::move(*vk);
  Session& ref = *s;
  const std::uint64_t id = runtime().sessions.insert(std::move(s));
  inst->session_id = id;
  // Nothing keeps a headless headset from showing the app at once: IDLE, then READY.
  set_session_state(id, ref, XR_SESSION_STATE_IDLE, kClockOrigin);
  set_session_state(id, ref, XR_SESSION_STATE_READY, kClockOrigin);
  *session = to_handle<XrSession>(id);
  return XR_SUCCESS;
}

void destroy_session(std::uint64_t session_id) {
  Runtime& rt = runtime();
  Session* s = rt.sessions.find(session_id);
  if (s == nullptr) return;
  for (std::uint64_t sc : rt.swapchains.ids_where([&](const Swapchain& c) { return c.session_id == session_id; }))
    destroy_swapchain(sc);
  for (std::uint64_t sp : rt.spaces.ids_where([&](const Space& c) { return c.session_id == session_id; }))
    rt.spaces.remove(sp);
  s->vk->destroy();
  if (Instance* inst = rt.instances.find(s->instance_id)) {
    if (!inst->capture_dir.empty()) {
      if (auto st = write_session_summary(*s, inst->capture_dir); !st) log_line("xrDestroySession: " + st.message());
    }
    // Events about a destroyed session are never delivered.
    std::erase_if(inst->events, [&](const PendingEvent& e) { return e.session_id == session_id; });
    inst->session_id = 0;
  }
  rt.sessions.remove(session_id);
  rt.frame_cv.notify_all();
}

XrResult xrDestroySession(XrSession session) {
  const auto lock = lock_runtime();
  if (find(session) == nullptr) return XR_ERROR_HANDLE_INVALID;
  destroy_session(to_id(session));
  return XR_SUCCESS;
}

XrResult xrBeginSession(XrSession session, const XrSessionBeginInfo* begin_info) {
  const char* fn = "xrBeginSession";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(begin_info, XR_TYPE_SESSION_BEGIN_INFO))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "beginInfo must be an XrSessionBeginInfo");
  if (begin_info->primaryViewConfigurationType != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  if (s->running) return fail(XR_ERROR_SESSION_RUNNING, fn, "the session is already running");
  if (s->state != XR_SESSION_STATE_READY)
    return fail(XR_ERROR_SESSION_NOT_READY, fn, std::string("the session is ") + session_state_name(s->state) + ", not READY");
  s->running = true;
  s->frame_open = false;
  return with_health(*s, XR_SUCCESS);
}

XrResult xrEndSession(XrSession session) {
  const char* fn = "xrEndSession";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!s->running) return fail(XR_ERROR_SESSION_NOT_RUNNING, fn, "the session is not running");
  if (s->state != XR_SESSION_STATE_STOPPING)
    return fail(XR_ERROR_SESSION_NOT_STOPPING, fn, std::string("the session is ") + session_state_name(s->state) + ", not STOPPING");
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const XrTime now = session_now(inst, *s);
  s->running = false;
  s->frame_open = false;
  set_session_state(to_id(session), *s, XR_SESSION_STATE_IDLE, now);
  // Stopping only ever comes from an exit here (script or xrRequestExitSession).
  if (s->exit_requested) set_session_state(to_id(session), *s, XR_SESSION_STATE_EXITING, now);
  runtime().frame_cv.notify_all();
  return with_health(*s, XR_SUCCESS);
}

XrResult xrRequestExitSession(XrSession session) {
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!s->running) return fail(XR_ERROR_SESSION_NOT_RUNNING, "xrRequestExitSession", "the session is not running");
  s->exit_requested = true;
  begin_stopping(to_id(session), *s, session_now(*runtime().instances.find(s->instance_id), *s));
  return with_health(*s, XR_SUCCESS);
}

}  // namespace gauss::xr_headless
