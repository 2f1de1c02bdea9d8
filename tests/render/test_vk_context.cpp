// Context creation and device choice: automatic choice, override by name (case-
// insensitive substring), by index, through $GAUSS_DEVICE, and the error for an
// override that matches nothing (which must list the available devices).
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"
#include "vk_test.h"

namespace {

using gauss::vk::Context;

class VkContextTest : public gauss::test::VkTest {};

// Restores an environment variable when the test ends, whatever happens.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) {
      old_ = old;
      had_ = true;
    }
    if (value) {
      ::setenv(name, value, 1);
    } else {
      ::unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (had_) {
      ::setenv(name_.c_str(), old_.c_str(), 1);
    } else {
      ::unsetenv(name_.c_str());
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::string old_;
  bool had_{false};
};

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

TEST_F(VkContextTest, ReportsDeviceAndLimits) {
  auto& ctx = context();
  EXPECT_FALSE(ctx.device_name().empty());
  EXPECT_NE(ctx.device(), VK_NULL_HANDLE);
  EXPECT_NE(ctx.queue(), VK_NULL_HANDLE);
  EXPECT_GE(ctx.properties().apiVersion, VK_API_VERSION_1_3);
  const std::uint32_t sg = ctx.subgroup_size();
  EXPECT_GT(sg, 0u);
  EXPECT_EQ(sg & (sg - 1), 0u) << "subgroup size " << sg << " is not a power of two";
  EXPECT_GT(ctx.max_storage_buffer_range(), 0u);
  EXPECT_GT(ctx.timestamp_period_ns(), 0.0);
  EXPECT_GT(ctx.timestamp_valid_bits(), 0u);
  EXPECT_TRUE(ctx.enabled_features13().dynamicRendering);
  EXPECT_TRUE(ctx.enabled_features13().synchronization2);
  const char* v = std::getenv("GAUSS_VALIDATION");
  const bool env_on = v && *v && std::string(v) != "0";
  EXPECT_EQ(ctx.validation_enabled(), env_on);
  if (ctx.device_name().find("llvmpipe") != std::string::npos) {
    EXPECT_EQ(ctx.max_storage_buffer_range(), 128u * 1024u * 1024u);
  }
}

TEST_F(VkContextTest, ListDevicesContainsTheChosenOne) {
  auto devices = Context::list_devices();
  ASSERT_TRUE(devices) << devices.message();
  ASSERT_FALSE(devices->empty());
  const auto it = std::find_if(devices->begin(), devices->end(),
                               [&](const gauss::vk::DeviceInfo& d) { return d.name == context().device_name(); });
  ASSERT_NE(it, devices->end());
  EXPECT_TRUE(it->unsuitable_reason.empty()) << it->unsuitable_reason;
}

TEST_F(VkContextTest, OverrideByNameSubstringIgnoresCase) {
  const std::string name = context().device_name();
  ASSERT_GE(name.size(), 4u);
  // A middle part of the name, upper-cased: still selects the device.
  const std::string part = upper(name.substr(1, std::min<std::size_t>(6, name.size() - 2)));
  auto ctx = Context::create({.app_name = "override-name", .device_override = part});
  ASSERT_TRUE(ctx) << ctx.message();
  EXPECT_EQ((*ctx)->device_name(), name);
}

TEST_F(VkContextTest, OverrideByIndex) {
  const std::uint32_t index = context().device_info().index;
  auto ctx = Context::create({.app_name = "override-index", .device_override = std::to_string(index)});
  ASSERT_TRUE(ctx) << ctx.message();
  EXPECT_EQ((*ctx)->device_info().index, index);
  EXPECT_EQ((*ctx)->device_name(), context().device_name());
}

TEST_F(VkContextTest, NonMatchingOverrideIsAnErrorListingDevices) {
  auto ctx = Context::create({.app_name = "override-bad", .device_override = "no-such-gpu-xyz"});
  ASSERT_FALSE(ctx);
  EXPECT_NE(ctx.message().find("no-such-gpu-xyz"), std::string::npos) << ctx.message();
  EXPECT_NE(ctx.message().find("--device"), std::string::npos) << ctx.message();
  EXPECT_NE(ctx.message().find(context().device_name()), std::string::npos)
      << "the error must list the available devices: " << ctx.message();

  auto out_of_range = Context::create({.app_name = "override-bad-index", .device_override = "97"});
  ASSERT_FALSE(out_of_range);
  EXPECT_NE(out_of_range.message().find(context().device_name()), std::string::npos) << out_of_range.message();
}

TEST_F(VkContextTest, EnvironmentOverrideIsUsedAndNamedInErrors) {
  {
    ScopedEnv env("GAUSS_DEVICE", "no-such-gpu-from-env");
    auto ctx = Context::create({.app_name = "env-bad"});
    ASSERT_FALSE(ctx);
    EXPECT_NE(ctx.message().find("GAUSS_DEVICE"), std::string::npos) << ctx.message();
    // The explicit override (an app's --device flag) wins over the environment.
    auto explicit_ctx = Context::create({.app_name = "env-vs-flag", .device_override = context().device_name()});
    ASSERT_TRUE(explicit_ctx) << explicit_ctx.message();
  }
  ScopedEnv env("GAUSS_DEVICE", std::to_string(context().device_info().index).c_str());
  auto ctx = Context::create({.app_name = "env-good"});
  ASSERT_TRUE(ctx) << ctx.message();
  EXPECT_EQ((*ctx)->device_name(), context().device_name());
}

TEST_F(VkContextTest, NoDriverIsAClearError) {
  // The loader finds its drivers again at every vkCreateInstance, so pointing it at a
  // driver file that does not exist looks exactly like a machine without Vulkan.
  // With validation on, the loader reports the missing driver through the messenger too.
  allow_validation_errors();
  ScopedEnv icd("VK_ICD_FILENAMES", "/nonexistent/gauss_no_driver.json");
  ScopedEnv files("VK_DRIVER_FILES", "/nonexistent/gauss_no_driver.json");
  auto ctx = Context::create({.app_name = "no-driver"});
  ASSERT_FALSE(ctx);
  EXPECT_NE(ctx.message().find("no Vulkan"), std::string::npos) << ctx.message();
}

TEST(VkDeviceArgs, ParsesDeviceFlag) {
  const char* a1[] = {"app", "--device", "llvmpipe", "--other"};
  EXPECT_EQ(gauss::vk::device_override_from_args(4, a1), "llvmpipe");
  const char* a2[] = {"app", "--device=1"};
  EXPECT_EQ(gauss::vk::device_override_from_args(2, a2), "1");
  const char* a3[] = {"app", "--device"};  // missing value: no override
  EXPECT_EQ(gauss::vk::device_override_from_args(2, a3), "");
  const char* a4[] = {"app", "--devices", "x"};
  EXPECT_EQ(gauss::vk::device_override_from_args(3, a4), "");
}

TEST(VkCheck, ResultNamesAndTryReturnsError) {
  EXPECT_STREQ(gauss::vk::result_name(VK_ERROR_OUT_OF_DEVICE_MEMORY), "VK_ERROR_OUT_OF_DEVICE_MEMORY");
  EXPECT_STREQ(gauss::vk::result_name(static_cast<VkResult>(-123456)), "VkResult(-123456)");
  auto failing = []() -> gauss::Status {
    GAUSS_VK_TRY(VK_ERROR_DEVICE_LOST);
    return gauss::Ok{};
  };
  auto st = failing();
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("VK_ERROR_DEVICE_LOST"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("test_vk_context.cpp"), std::string::npos) << st.message();
}

TEST(VkCheckDeathTest, FatalCheckNamesCallFileAndResult) {
  EXPECT_DEATH(GAUSS_VK_CHECK(VK_ERROR_INITIALIZATION_FAILED),
               "test_vk_context.cpp:[0-9]+: fatal Vulkan error: VK_ERROR_INITIALIZATION_FAILED failed with "
               "VK_ERROR_INITIALIZATION_FAILED");
}

}  // namespace

namespace {

// An XR runtime creates the instance and device (XR_KHR_vulkan_enable2): the Context hands
// it the create infos it would use itself, takes the device it names, and works on the
// result as on its own.
TEST_F(VkContextTest, AnXrRuntimeCanCreateTheInstanceAndDevice) {
  int instances = 0, devices = 0, asked = 0;
  gauss::vk::ContextCreateInfo ci;
  ci.create_instance = [&](const VkInstanceCreateInfo& info) -> gauss::Expected<VkInstance> {
    ++instances;
    EXPECT_EQ(info.pApplicationInfo->apiVersion, VK_API_VERSION_1_3);
    VkInstance out = VK_NULL_HANDLE;
    if (vkCreateInstance(&info, nullptr, &out) != VK_SUCCESS) return gauss::Error{"vkCreateInstance"};
    return out;
  };
  ci.required_physical_device = [&](VkInstance instance) -> gauss::Expected<VkPhysicalDevice> {
    ++asked;
    std::uint32_t n = 1;
    VkPhysicalDevice first = VK_NULL_HANDLE;
    vkEnumeratePhysicalDevices(instance, &n, &first);
    return first;
  };
  ci.create_device = [&](VkPhysicalDevice physical, const VkDeviceCreateInfo& info) -> gauss::Expected<VkDevice> {
    ++devices;
    EXPECT_GE(info.enabledExtensionCount, 1u) << "push descriptors at least";
    VkDevice out = VK_NULL_HANDLE;
    if (vkCreateDevice(physical, &info, nullptr, &out) != VK_SUCCESS) return gauss::Error{"vkCreateDevice"};
    return out;
  };
  auto ctx = Context::create(ci);
  ASSERT_TRUE(ctx) << ctx.message();
  EXPECT_EQ(instances, 1);
  EXPECT_EQ(asked, 1);
  EXPECT_EQ(devices, 1);
  EXPECT_NE((*ctx)->queue(), VK_NULL_HANDLE);
  auto idle = (*ctx)->wait_idle();
  EXPECT_TRUE(idle) << idle.message();

  // A runtime that fails is named in the error, and nothing leaks (validation would say).
  gauss::vk::ContextCreateInfo failing;
  failing.create_instance = [](const VkInstanceCreateInfo&) -> gauss::Expected<VkInstance> {
    return gauss::Error{"the headset is asleep"};
  };
  auto none = Context::create(failing);
  ASSERT_FALSE(none);
  EXPECT_NE(none.message().find("the headset is asleep"), std::string::npos) << none.message();
  EXPECT_NE(none.message().find("XR runtime"), std::string::npos) << none.message();
}

}  // namespace
