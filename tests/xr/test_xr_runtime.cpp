#include "gauss/xr/xr_runtime.h"

#include <cstdlib>

#include <gtest/gtest.h>

namespace gauss::xr {
namespace {

// CI machines have no OpenXR runtime: opening must fail cleanly with a message that
// says what is missing. On a machine with a runtime and headset it must succeed
// and report sensible per-eye sizes.
TEST(XrRuntime, OpensOrExplainsWhy) {
  auto rt = XrRuntime::open("gauss-test");
  if (rt) {
    EXPECT_GT(rt.value()->info().recommended_width, 0u);
    EXPECT_GT(rt.value()->info().recommended_height, 0u);
  } else {
    EXPECT_NE(rt.message().find("OpenXR"), std::string::npos) << rt.message();
  }
}

TEST(XrRuntime, MissingRuntimeManifestIsAnErrorNotACrash) {
  setenv("XR_RUNTIME_JSON", "/nonexistent/openxr_runtime.json", 1);
  auto rt = XrRuntime::open("gauss-test");
  ASSERT_FALSE(rt);
  EXPECT_NE(rt.message().find("no OpenXR runtime"), std::string::npos) << rt.message();
}

}  // namespace
}  // namespace gauss::xr
