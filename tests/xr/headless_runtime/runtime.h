#pragma once
// The runtime's objects and the one lock that guards them. Every entry point takes the
// lock first (lock_runtime()), so the OpenXR objects are never seen half-changed; the
// frame loop's only blocking wait (a second xrWaitFrame before xrBeginFrame) sleeps on
// frame_cv with the lock released.
//
// Ownership follows the OpenXR handle tree: an instance owns its sessions and action
// sets, a session owns its spaces and swapchains; destroying a parent destroys the
// children (destroy_session & co. below).
#include <array>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "handles.h"
#include "interaction_profiles.h"
#include "paths.h"
#include "script.h"
#include "vk_device.h"
#include "xr_headers.h"

namespace gauss::xr_headless {

// The one system: a head-mounted display.
inline constexpr XrSystemId kSystemId = 1;
// Virtual clock: session time starts here (XrTime 0 means "no time" in places) and frame
// k is displayed at kClockOrigin + (k + 1) * period. No real time passes.
inline constexpr XrTime kClockOrigin = 1'000'000'000;
// The swapchain image count: triple buffering, as most headsets.
inline constexpr std::uint32_t kSwapchainImageCount = 3;
// Queued events beyond this are dropped (the spec's XrEventDataEventsLost is not sent).
inline constexpr std::size_t kMaxQueuedEvents = 256;

struct PendingEvent {
  std::uint64_t session_id{0};  // 0: not about a session
  XrEventDataBuffer data{};
};

struct SuggestedBinding {
  std::uint64_t action_id{0};
  XrPath binding{XR_NULL_PATH};
  BindingTarget target;
};

struct Instance {
  Script script;
  std::filesystem::path capture_dir;  // empty: GAUSS_XR_HEADLESS_CAPTURE unset
  bool vulkan_enable2{false};
  bool composition_layer_depth{false};
  bool graphics_requirements_queried{false};  // xrCreateSession requires it (vulkan_enable2)
  PathTable paths;
  std::deque<PendingEvent> events;
  // Vulkan objects made through xrCreateVulkanInstanceKHR / handed out by
  // xrGetVulkanGraphicsDevice2KHR / made through xrCreateVulkanDeviceKHR.
  std::map<VkInstance, PFN_vkGetInstanceProcAddr> vk_instances;
  std::map<VkPhysicalDevice, VkInstance> vk_physical_devices;
  std::map<VkDevice, std::map<std::uint32_t, std::uint32_t>> vk_device_queues;  // family -> queue count
  std::map<XrPath, std::vector<SuggestedBinding>> suggested_bindings;  // per interaction profile
  bool action_sets_attached{false};  // bindings are fixed once any session attached its sets
  std::uint64_t session_id{0};       // the live session (one at a time), 0 if none
};

// The state of one action for one subaction slot (any hand, left, right) as of the last xrSyncActions.
struct ActionSlotState {
  bool active{false};
  bool boolean{false};
  float value{0.0f};
  XrVector2f vector{0.0f, 0.0f};
  bool changed{false};
  XrTime last_change{0};
};

// Subaction slots: index 0 is "any" (XR_NULL_PATH), then the hands.
inline constexpr int kSlotAny = 0;
inline constexpr int kSlotLeft = 1;
inline constexpr int kSlotRight = 2;

struct Session {
  std::uint64_t instance_id{0};
  std::unique_ptr<VulkanDevice> vk;
  XrSessionState state{XR_SESSION_STATE_UNKNOWN};
  std::vector<XrSessionState> state_history;
  bool running{false};         // between xrBeginSession and xrEndSession
  bool exit_requested{false};  // scripted "exit" or xrRequestExitSession: EXITING after xrEndSession
  bool loss_pending{false};    // scripted "loss" happened
  bool loss_delivered{false};  // ...and the app polled its LOSS_PENDING event: now XR_ERROR_SESSION_LOST
  // Frame loop. The frame index is the count of xrWaitFrame (= xrBeginFrame) calls before it.
  std::uint64_t frames_waited{0};
  std::uint64_t frames_begun{0};
  std::uint64_t frames_ended{0};
  bool frame_open{false};  // begun and not yet ended
  std::vector<std::uint64_t> captured_frames;
  std::vector<std::uint64_t> quad_frames;  // frames ended with a quad layer (e.g. a status banner)
  // Actions.
  bool actions_attached{false};
  std::vector<std::uint64_t> attached_sets;
  XrPath profile{XR_NULL_PATH};  // current interaction profile of both hands
  std::map<std::uint64_t, std::vector<SuggestedBinding>> bindings;  // attached action -> its inputs in `profile`
  std::map<std::uint64_t, std::array<ActionSlotState, 3>> action_states;
  std::map<std::uint64_t, std::array<bool, 3>> active_sets;  // per action set and slot, as last synced
};

struct Space {
  std::uint64_t session_id{0};
  bool is_action{false};
  XrReferenceSpaceType reference{XR_REFERENCE_SPACE_TYPE_STAGE};
  std::uint64_t action_id{0};
  int slot{kSlotAny};
  XrPosef offset{};  // poseInReferenceSpace / poseInActionSpace
};

struct Swapchain {
  std::uint64_t session_id{0};
  XrSwapchainCreateInfo info{};  // next cleared
  VkFormat format{VK_FORMAT_UNDEFINED};
  bool depth{false};
  std::vector<VkImage> images;
  std::vector<VkDeviceMemory> memory;
  bool layouts_initialized{false};  // images moved to the attachment layout (first acquire)
  std::deque<std::uint32_t> acquired;  // acquired, not yet waited, oldest first
  std::optional<std::uint32_t> waited;  // waited, not yet released
  std::uint32_t next_index{0};
  std::optional<std::uint32_t> last_released;
};

struct ActionSet {
  std::uint64_t instance_id{0};
  std::string name;
  std::string localized_name;
  std::uint32_t priority{0};
  bool attached{false};
};

struct Action {
  std::uint64_t instance_id{0};
  std::uint64_t set_id{0};
  std::string name;
  std::string localized_name;
  XrActionType type{XR_ACTION_TYPE_BOOLEAN_INPUT};
  std::vector<XrPath> subaction_paths;
};

struct Runtime {
  std::mutex mutex;
  std::condition_variable frame_cv;
  HandleTable<Instance> instances;
  HandleTable<Session> sessions;
  HandleTable<Space> spaces;
  HandleTable<Swapchain> swapchains;
  HandleTable<ActionSet> action_sets;
  HandleTable<Action> actions;
};

Runtime& runtime();
std::unique_lock<std::mutex> lock_runtime();

// Lookups by handle: the live object or nullptr (the caller returns XR_ERROR_HANDLE_INVALID).
Instance* find(XrInstance handle);
Session* find(XrSession handle);
Space* find(XrSpace handle);
Swapchain* find(XrSwapchain handle);
ActionSet* find(XrActionSet handle);
Action* find(XrAction handle);

// Cascading destruction (the caller holds the lock and has checked the id).
void destroy_session(std::uint64_t session_id);
void destroy_swapchain(std::uint64_t swapchain_id);
void destroy_action_set(std::uint64_t set_id);

// Session lifecycle (session_state.cpp).
void queue_event(Instance& instance, const PendingEvent& event);
void set_session_state(std::uint64_t session_id, Session& session, XrSessionState state, XrTime time);
// Walks a running session down through VISIBLE and SYNCHRONIZED to STOPPING, as the
// spec's lifecycle diagram requires, for a scripted exit or xrRequestExitSession.
void begin_stopping(std::uint64_t session_id, Session& session, XrTime time);
// XR_SUCCESS, XR_SESSION_LOSS_PENDING (loss scripted, app not yet told) or
// XR_ERROR_SESSION_LOST (the app polled LOSS_PENDING): every session call checks this.
XrResult session_health(const Session& session);
// `ok` unless the session is losing or lost (then the health code).
XrResult with_health(const Session& session, XrResult ok);

// Time of the frame loop (frame.cpp): the display time of frame `index`, the frame shown
// at `time`, and the session's "now" (the display time of the frame last waited on).
XrTime display_time(const Instance& instance, std::uint64_t index);
std::uint64_t frame_at(const Instance& instance, XrTime time);
XrTime session_now(const Instance& instance, const Session& session);

// The pose of `space` in STAGE space at `time`, or nullopt when it is not tracked now (an
// action space whose action is inactive). spaces.cpp.
std::optional<XrPosef> space_in_stage(const Instance& instance, const Session& session, const Space& space, XrTime time);

// The subaction slot of `path` for `action` (kSlotAny for XR_NULL_PATH), or -1 when the
// action was not created with that subaction path (XR_ERROR_PATH_UNSUPPORTED). actions.cpp.
int subaction_slot(const Instance& instance, const Action& action, XrPath path);
// Whether the action's set is attached to `session`. actions.cpp.
bool attached_to(const Session& session, const Action& action);

// The STAGE pose of a pose action's input for `slot`, or nullopt if inactive. action_state.cpp.
std::optional<XrPosef> action_pose(const Instance& instance, const Session& session, std::uint64_t action_id, int slot,
                                   std::uint64_t frame);

}  // namespace gauss::xr_headless
