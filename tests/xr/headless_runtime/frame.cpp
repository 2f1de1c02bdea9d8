// The frame loop on a virtual clock: xrWaitFrame never sleeps (frame k is displayed at
// kClockOrigin + (k + 1) * period), scripted events fire when their frame is waited on,
// xrEndFrame validates the layers as the spec requires and triggers the readback.
//
// Session states advance with the loop: the first xrWaitFrame after xrBeginSession moves
// READY -> SYNCHRONIZED, the next two submitted frames -> VISIBLE -> FOCUSED. shouldRender
// is true while VISIBLE or FOCUSED.
#include <cmath>

#include "entry_points.h"
#include "readback.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

// Checks one swapchain sub-image of a layer; fills `out` on success.
XrResult check_sub_image(const char* fn, const std::string& where, std::uint64_t session_id,
                         const XrSwapchainSubImage& sub, bool want_depth, const Swapchain** out) {
  const Swapchain* sc = find(sub.swapchain);
  if (sc == nullptr) return fail(XR_ERROR_HANDLE_INVALID, fn, where + ".swapchain is not a live XrSwapchain");
  if (sc->session_id != session_id) return fail(XR_ERROR_VALIDATION_FAILURE, fn, where + ".swapchain belongs to another session");
  if (sc->depth != want_depth)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, where + (want_depth ? " needs a depth swapchain" : " needs a colour swapchain"));
  if (!sc->last_released)
    return fail(XR_ERROR_LAYER_INVALID, fn, where + ".swapchain has no released image (acquire, wait, render, release first)");
  const XrRect2Di& r = sub.imageRect;
  if (r.offset.x < 0 || r.offset.y < 0 || r.extent.width <= 0 || r.extent.height <= 0 ||
      std::int64_t(r.offset.x) + r.extent.width > std::int64_t(sc->info.width) ||
      std::int64_t(r.offset.y) + r.extent.height > std::int64_t(sc->info.height))
    return fail(XR_ERROR_SWAPCHAIN_RECT_INVALID, fn,
                where + ".imageRect (" + std::to_string(r.offset.x) + "," + std::to_string(r.offset.y) + " " +
                    std::to_string(r.extent.width) + "x" + std::to_string(r.extent.height) + ") is outside the " +
                    std::to_string(sc->info.width) + "x" + std::to_string(sc->info.height) + " swapchain");
  if (sub.imageArrayIndex >= sc->info.arraySize)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, where + ".imageArrayIndex is beyond the swapchain's arraySize");
  *out = sc;
  return XR_SUCCESS;
}

XrResult check_projection(const Instance& inst, std::uint64_t session_id, const XrCompositionLayerProjection& layer,
                          const std::string& where, CapturedFrame& out) {
  const char* fn = "xrEndFrame";
  const Space* space = find(layer.space);
  if (space == nullptr) return fail(XR_ERROR_HANDLE_INVALID, fn, where + ".space is not a live XrSpace");
  if (space->session_id != session_id) return fail(XR_ERROR_VALIDATION_FAILURE, fn, where + ".space belongs to another session");
  if (layer.viewCount != 2 || layer.views == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, where + " must have 2 views (PRIMARY_STEREO)");
  out.space = space->is_action ? "action" : reference_space_name(space->reference);
  out.layer_flags = layer.layerFlags;
  out.views.clear();
  for (std::uint32_t v = 0; v < 2; ++v) {
    const XrCompositionLayerProjectionView& view = layer.views[v];
    const std::string vw = where + ".views[" + std::to_string(v) + "]";
    if (view.type != XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW)
      return fail(XR_ERROR_VALIDATION_FAILURE, fn, vw + " is not an XrCompositionLayerProjectionView");
    if (!valid_pose(view.pose)) return fail(XR_ERROR_POSE_INVALID, fn, vw + ".pose has a non-unit orientation");
    const XrFovf& f = view.fov;
    if (!std::isfinite(f.angleLeft) || !std::isfinite(f.angleRight) || !std::isfinite(f.angleUp) || !std::isfinite(f.angleDown))
      return fail(XR_ERROR_VALIDATION_FAILURE, fn, vw + ".fov is not finite");
    CapturedView cv;
    if (const XrResult r = check_sub_image(fn, vw + ".subImage", session_id, view.subImage, false, &cv.swapchain); XR_FAILED(r))
      return r;
    cv.rect = view.subImage.imageRect;
    cv.array_index = view.subImage.imageArrayIndex;
    cv.pose = view.pose;
    cv.fov = view.fov;
    if (const auto* d = static_cast<const XrCompositionLayerDepthInfoKHR*>(
            find_in_chain(view.next, XR_TYPE_COMPOSITION_LAYER_DEPTH_INFO_KHR))) {
      const std::string dw = vw + ".next(XrCompositionLayerDepthInfoKHR)";
      if (!inst.composition_layer_depth)
        return fail(XR_ERROR_VALIDATION_FAILURE, fn, dw + ": XR_KHR_composition_layer_depth is not enabled");
      CapturedDepth cd;
      if (const XrResult r = check_sub_image(fn, dw + ".subImage", session_id, d->subImage, true, &cd.swapchain); XR_FAILED(r))
        return r;
      if (!(d->minDepth >= 0.0f && d->minDepth < d->maxDepth && d->maxDepth <= 1.0f) || !std::isfinite(d->nearZ) ||
          !std::isfinite(d->farZ) || d->nearZ == d->farZ)
        return fail(XR_ERROR_VALIDATION_FAILURE, fn, dw + ": needs 0 <= minDepth < maxDepth <= 1 and nearZ != farZ");
      cd.rect = d->subImage.imageRect;
      cd.array_index = d->subImage.imageArrayIndex;
      cd.min_depth = d->minDepth;
      cd.max_depth = d->maxDepth;
      cd.near_z = d->nearZ;
      cd.far_z = d->farZ;
      cv.depth = cd;
    }
    out.views.push_back(cv);
  }
  return XR_SUCCESS;
}

// Quad layers are core OpenXR: validated and accepted, but not captured.
XrResult check_quad(std::uint64_t session_id, const XrCompositionLayerQuad& layer, const std::string& where) {
  const char* fn = "xrEndFrame";
  const Space* space = find(layer.space);
  if (space == nullptr) return fail(XR_ERROR_HANDLE_INVALID, fn, where + ".space is not a live XrSpace");
  if (space->session_id != session_id) return fail(XR_ERROR_VALIDATION_FAILURE, fn, where + ".space belongs to another session");
  if (!valid_pose(layer.pose)) return fail(XR_ERROR_POSE_INVALID, fn, where + ".pose has a non-unit orientation");
  const Swapchain* sc = nullptr;
  return check_sub_image(fn, where + ".subImage", session_id, layer.subImage, false, &sc);
}

}  // namespace

XrTime display_time(const Instance& instance, std::uint64_t index) {
  return kClockOrigin + static_cast<XrTime>(index + 1) * instance.script.period_ns;
}

std::uint64_t frame_at(const Instance& instance, XrTime time) {
  const XrTime period = instance.script.period_ns;
  const XrTime first = display_time(instance, 0);
  if (time <= first) return 0;
  return static_cast<std::uint64_t>((time - first + period / 2) / period);  // the nearest frame
}

XrTime session_now(const Instance& instance, const Session& session) {
  return session.frames_waited == 0 ? kClockOrigin : display_time(instance, session.frames_waited - 1);
}

XrResult xrWaitFrame(XrSession session, const XrFrameWaitInfo* wait_info, XrFrameState* frame_state) {
  const char* fn = "xrWaitFrame";
  auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if ((wait_info != nullptr && wait_info->type != XR_TYPE_FRAME_WAIT_INFO) || !typed(frame_state, XR_TYPE_FRAME_STATE))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "frameWaitInfo must be null or an XrFrameWaitInfo, frameState an XrFrameState");
  if (!s->running) return fail(XR_ERROR_SESSION_NOT_RUNNING, fn, "the session is not running (xrBeginSession first)");
  // A second xrWaitFrame blocks until the previous frame's xrBeginFrame (spec), e.g. from
  // the app's render thread; the lock is released while waiting.
  const std::uint64_t id = to_id(session);
  runtime().frame_cv.wait(lock, [&] {
    Session* cur = runtime().sessions.find(id);
    return cur == nullptr || !cur->running || cur->frames_waited == cur->frames_begun;
  });
  s = runtime().sessions.find(id);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!s->running) return XR_ERROR_SESSION_NOT_RUNNING;
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const std::uint64_t k = s->frames_waited;
  const XrTime now = k == 0 ? kClockOrigin : display_time(inst, k - 1);
  for (const ScriptEvent& ev : inst.script.events) {
    if (ev.frame != k || s->loss_pending) continue;
    if (ev.kind == ScriptEventKind::kLoss) {
      s->loss_pending = true;
      set_session_state(id, *s, XR_SESSION_STATE_LOSS_PENDING, now);
    } else if (!s->exit_requested) {
      s->exit_requested = true;
      begin_stopping(id, *s, now);
    }
  }
  if (s->state == XR_SESSION_STATE_READY) set_session_state(id, *s, XR_SESSION_STATE_SYNCHRONIZED, now);
  s->frames_waited = k + 1;
  frame_state->predictedDisplayTime = display_time(inst, k);
  frame_state->predictedDisplayPeriod = inst.script.period_ns;
  frame_state->shouldRender = s->state == XR_SESSION_STATE_VISIBLE || s->state == XR_SESSION_STATE_FOCUSED;
  return with_health(*s, XR_SUCCESS);
}

XrResult xrBeginFrame(XrSession session, const XrFrameBeginInfo* begin_info) {
  const char* fn = "xrBeginFrame";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (begin_info != nullptr && begin_info->type != XR_TYPE_FRAME_BEGIN_INFO)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "frameBeginInfo must be null or an XrFrameBeginInfo");
  if (!s->running) return fail(XR_ERROR_SESSION_NOT_RUNNING, fn, "the session is not running");
  if (s->frames_begun == s->frames_waited)
    return fail(XR_ERROR_CALL_ORDER_INVALID, fn, "no xrWaitFrame since the last xrBeginFrame");
  const bool discarded = s->frame_open;
  s->frame_open = true;
  ++s->frames_begun;
  runtime().frame_cv.notify_all();
  return with_health(*s, discarded ? XR_FRAME_DISCARDED : XR_SUCCESS);
}

XrResult xrEndFrame(XrSession session, const XrFrameEndInfo* end_info) {
  const char* fn = "xrEndFrame";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(end_info, XR_TYPE_FRAME_END_INFO)) return fail(XR_ERROR_VALIDATION_FAILURE, fn, "frameEndInfo must be an XrFrameEndInfo");
  if (!s->running) return fail(XR_ERROR_SESSION_NOT_RUNNING, fn, "the session is not running");
  if (!s->frame_open) return fail(XR_ERROR_CALL_ORDER_INVALID, fn, "no xrBeginFrame before this xrEndFrame");
  if (end_info->displayTime <= 0) return fail(XR_ERROR_TIME_INVALID, fn, "displayTime must be > 0");
  if (end_info->environmentBlendMode != XR_ENVIRONMENT_BLEND_MODE_OPAQUE)
    return fail(XR_ERROR_ENVIRONMENT_BLEND_MODE_UNSUPPORTED, fn, "only OPAQUE is supported");
  if (end_info->layerCount > XR_MIN_COMPOSITION_LAYERS_SUPPORTED)
    return fail(XR_ERROR_LAYER_LIMIT_EXCEEDED, fn, "more than 16 layers");
  if (end_info->layerCount > 0 && end_info->layers == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "layerCount > 0 but layers is null");
  const std::uint64_t id = to_id(session);
  const Instance& inst = *runtime().instances.find(s->instance_id);
  const std::uint64_t index = s->frames_begun - 1;

  CapturedFrame frame;
  bool have_projection = false, have_quad = false;
  for (std::uint32_t i = 0; i < end_info->layerCount; ++i) {
    const XrCompositionLayerBaseHeader* layer = end_info->layers[i];
    const std::string where = "layers[" + std::to_string(i) + "]";
    if (layer == nullptr) return fail(XR_ERROR_LAYER_INVALID, fn, where + " is null");
    XrResult r = XR_SUCCESS;
    if (layer->type == XR_TYPE_COMPOSITION_LAYER_PROJECTION) {
      CapturedFrame candidate;
      r = check_projection(inst, id, *reinterpret_cast<const XrCompositionLayerProjection*>(layer), where, candidate);
      if (XR_SUCCEEDED(r) && !have_projection) {  // the first projection layer is the one captured
        frame = candidate;
        have_projection = true;
      }
    } else if (layer->type == XR_TYPE_COMPOSITION_LAYER_QUAD) {
      r = check_quad(id, *reinterpret_cast<const XrCompositionLayerQuad*>(layer), where);
      have_quad = true;
    } else {
      r = fail(XR_ERROR_LAYER_INVALID, fn, where + " is neither a projection nor a quad layer");
    }
    if (XR_FAILED(r)) return r;
  }

  s->frame_open = false;
  ++s->frames_ended;
  if (have_quad) s->quad_frames.push_back(index);
  if (have_projection && !inst.capture_dir.empty() && inst.script.captures(index)) {
    frame.index = index;
    frame.predicted_display_time = display_time(inst, index);
    frame.display_time = end_info->displayTime;
    if (auto st = capture_frame(*s->vk, inst.capture_dir, frame); !st) return fail(XR_ERROR_RUNTIME_FAILURE, fn, st.message());
    s->captured_frames.push_back(index);
  }
  if (!s->exit_requested && !s->loss_pending) {
    const XrTime now = session_now(inst, *s);
    if (s->state == XR_SESSION_STATE_VISIBLE) set_session_state(id, *s, XR_SESSION_STATE_FOCUSED, now);
    if (s->state == XR_SESSION_STATE_SYNCHRONIZED) set_session_state(id, *s, XR_SESSION_STATE_VISIBLE, now);
  }
  return with_health(*s, XR_SUCCESS);
}

}  // namespace gauss::xr_headless
