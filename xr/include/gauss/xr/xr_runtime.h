#pragma once
// Connects to the OpenXR runtime: instance with XR_KHR_vulkan_enable2 and the
// head-mounted-display system. Without a runtime (desktop CI) it returns a clear
// error instead of crashing, so the desktop viewer can fall back to a window.
#include <cstdint>
#include <memory>
#include <string>

#include "gauss/engine/result.h"

namespace gauss::xr {

struct XrRuntimeInfo {
  std::string runtime_name;
  std::string system_name;
  std::uint32_t recommended_width{0};   // per eye, from the first view configuration view
  std::uint32_t recommended_height{0};
};

class XrRuntime {
 public:
  // Creates the instance and finds the HMD system. Errors: no runtime installed or
  // active, XR_KHR_vulkan_enable2 missing, no headset connected.
  static Expected<std::unique_ptr<XrRuntime>> open(const std::string& app_name);
  ~XrRuntime();
  XrRuntime(const XrRuntime&) = delete;
  XrRuntime& operator=(const XrRuntime&) = delete;

  const XrRuntimeInfo& info() const { return info_; }

 private:
  XrRuntime() = default;
  struct Handles;
  std::unique_ptr<Handles> handles_;
  XrRuntimeInfo info_;
};

}  // namespace gauss::xr
