// The session lifecycle: state changes become XrEventDataSessionStateChanged events in the
// instance's queue, in the order the spec's lifecycle diagram allows; xrPollEvent hands
// them out. Loss: after a scripted "loss" the session answers XR_SESSION_LOSS_PENDING
// until the app has polled the LOSS_PENDING event, then XR_ERROR_SESSION_LOST.
#include <cstring>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {

void queue_event(Instance& instance, const PendingEvent& event) {
  if (instance.events.size() >= kMaxQueuedEvents) {
    log_line("event queue full: an event was dropped (is the app calling xrPollEvent?)");
    return;
  }
  instance.events.push_back(event);
}

void set_session_state(std::uint64_t session_id, Session& session, XrSessionState state, XrTime time) {
  session.state = state;
  session.state_history.push_back(state);
  PendingEvent ev;
  ev.session_id = session_id;
  auto* changed = reinterpret_cast<XrEventDataSessionStateChanged*>(&ev.data);
  changed->type = XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED;
  changed->next = nullptr;
  changed->session = to_handle<XrSession>(session_id);
  changed->state = state;
  changed->time = time;
  if (Instance* inst = runtime().instances.find(session.instance_id)) queue_event(*inst, ev);
}

void begin_stopping(std::uint64_t session_id, Session& session, XrTime time) {
  if (session.state == XR_SESSION_STATE_FOCUSED) set_session_state(session_id, session, XR_SESSION_STATE_VISIBLE, time);
  if (session.state == XR_SESSION_STATE_VISIBLE)
    set_session_state(session_id, session, XR_SESSION_STATE_SYNCHRONIZED, time);
  // Begun but no frame waited yet: the spec lets the runtime pass through SYNCHRONIZED.
  if (session.state == XR_SESSION_STATE_READY) set_session_state(session_id, session, XR_SESSION_STATE_SYNCHRONIZED, time);
  if (session.state == XR_SESSION_STATE_SYNCHRONIZED)
    set_session_state(session_id, session, XR_SESSION_STATE_STOPPING, time);
}

XrResult session_health(const Session& session) {
  if (session.loss_delivered) return XR_ERROR_SESSION_LOST;
  if (session.loss_pending) return XR_SESSION_LOSS_PENDING;
  return XR_SUCCESS;
}

XrResult with_health(const Session& session, XrResult ok) {
  const XrResult health = session_health(session);
  return health == XR_SUCCESS ? ok : health;
}

XrResult xrPollEvent(XrInstance instance, XrEventDataBuffer* event_data) {
  const auto lock = lock_runtime();
  Instance* inst = find(instance);
  if (inst == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!typed(event_data, XR_TYPE_EVENT_DATA_BUFFER))
    return fail(XR_ERROR_VALIDATION_FAILURE, "xrPollEvent", "eventData must be an XrEventDataBuffer");
  if (inst->events.empty()) return XR_EVENT_UNAVAILABLE;
  const PendingEvent ev = inst->events.front();
  inst->events.pop_front();
  std::memcpy(event_data, &ev.data, sizeof(XrEventDataBuffer));
  if (ev.data.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED &&
      reinterpret_cast<const XrEventDataSessionStateChanged*>(&ev.data)->state == XR_SESSION_STATE_LOSS_PENDING) {
    if (Session* s = runtime().sessions.find(ev.session_id)) s->loss_delivered = true;
  }
  return XR_SUCCESS;
}

}  // namespace gauss::xr_headless
