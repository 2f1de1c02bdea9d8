#include "runtime.h"

namespace gauss::xr_headless {

Runtime& runtime() {
  // Destroyed when the loader unloads the library (or at exit): by then the app has
  // destroyed its instances, and an app that did not still only loses host memory, since
  // no destructor here calls Vulkan (destroy_session does that explicitly).
  static Runtime rt;
  return rt;
}

std::unique_lock<std::mutex> lock_runtime() { return std::unique_lock<std::mutex>(runtime().mutex); }

std::uint64_t next_handle_id() {
  static std::uint64_t next = 0x1000;  // small integers look like indices: keep them out
  return next++;
}

Instance* find(XrInstance handle) { return runtime().instances.find(to_id(handle)); }
Session* find(XrSession handle) { return runtime().sessions.find(to_id(handle)); }
Space* find(XrSpace handle) { return runtime().spaces.find(to_id(handle)); }
Swapchain* find(XrSwapchain handle) { return runtime().swapchains.find(to_id(handle)); }
ActionSet* find(XrActionSet handle) { return runtime().action_sets.find(to_id(handle)); }
Action* find(XrAction handle) { return runtime().actions.find(to_id(handle)); }

}  // namespace gauss::xr_headless
