#include "gauss/xr/xr_runtime.h"

#include <vector>

#include <openxr/openxr.h>

#include "xr_check.h"
#include "xr_instance.h"

namespace gauss::xr {
namespace {

using detail::result_text;
using detail::xr_struct;

}  // namespace

struct XrRuntime::Handles {
  XrInstance instance{XR_NULL_HANDLE};
  ~Handles() {
    if (instance != XR_NULL_HANDLE) xrDestroyInstance(instance);
  }
};

XrRuntime::~XrRuntime() = default;

Expected<std::unique_ptr<XrRuntime>> XrRuntime::open(const std::string& app_name) {
  auto opened = detail::open_instance(app_name, false);
  if (!opened) return opened.error();
  auto rt = std::unique_ptr<XrRuntime>(new XrRuntime());
  rt->handles_ = std::make_unique<Handles>();
  rt->handles_->instance = opened->instance;
  XrInstance inst = rt->handles_->instance;

  auto props = xr_struct<XrInstanceProperties>(XR_TYPE_INSTANCE_PROPERTIES);
  if (XR_SUCCEEDED(xrGetInstanceProperties(inst, &props))) rt->info_.runtime_name = props.runtimeName;

  auto sgi = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
  sgi.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
  XrSystemId system = XR_NULL_SYSTEM_ID;
  XrResult r = xrGetSystem(inst, &sgi, &system);
  if (XR_FAILED(r)) return Error{"OpenXR: no head-mounted display (" + result_text(inst, r) + ")"};
  auto sp = xr_struct<XrSystemProperties>(XR_TYPE_SYSTEM_PROPERTIES);
  if (XR_SUCCEEDED(xrGetSystemProperties(inst, system, &sp))) rt->info_.system_name = sp.systemName;

  std::uint32_t views = 0;
  r = xrEnumerateViewConfigurationViews(inst, system, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 0, &views, nullptr);
  if (XR_FAILED(r) || views != 2) return Error{"OpenXR: the headset offers no primary stereo view configuration"};
  std::vector<XrViewConfigurationView> vcv(views, xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW));
  r = xrEnumerateViewConfigurationViews(inst, system, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, views, &views, vcv.data());
  if (XR_FAILED(r)) return Error{"OpenXR: reading the stereo views failed (" + result_text(inst, r) + ")"};
  rt->info_.recommended_width = vcv[0].recommendedImageRectWidth;
  rt->info_.recommended_height = vcv[0].recommendedImageRectHeight;
  return rt;
}

}  // namespace gauss::xr
