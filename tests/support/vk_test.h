#pragma once
// GPU test support: one shared gauss::vk::Context per test executable, and a fixture
// that fails any test during which Vulkan validation reported an error (CTest runs
// every test with GAUSS_VALIDATION=1, so validation is on there).
//
//   class MyGpuTest : public gauss::test::VkTest {};
//   TEST_F(MyGpuTest, Draws) { auto& ctx = context(); ... }
//
// The check uses the process-wide validation error count, so it also covers contexts
// a test creates itself. A test that provokes validation errors on purpose calls
// allow_validation_errors(). No usable Vulkan device fails the test with the reason.
// With GAUSS_EXPECT_SUBGROUP_SIZE set (the LP_NATIVE_VECTOR_WIDTH variants in
// tests/CMakeLists.txt), every test first checks the device really has that subgroup
// size, so a variant can never silently repeat the default run.
#include <cstdlib>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "gauss/render/vk_context.h"

namespace gauss::test {

namespace detail {

struct SharedVkContext {
  std::unique_ptr<vk::Context> context;
  std::string error;
  bool tried{false};
};

inline SharedVkContext& shared_vk_context_storage() {
  static SharedVkContext storage;
  return storage;
}

// Destroys the shared context after the last test (validation reports leaked objects
// when the device is destroyed) and fails the run if that produced errors.
class VkEnvironment : public ::testing::Environment {
 public:
  void TearDown() override {
    auto& s = shared_vk_context_storage();
    if (!s.context) return;
    const auto before = vk::process_validation_error_count();
    s.context.reset();
    EXPECT_EQ(vk::process_validation_error_count(), before)
        << "Vulkan validation errors while destroying the shared context (leaked objects?)";
  }
};

inline ::testing::Environment* const vk_environment = ::testing::AddGlobalTestEnvironment(new VkEnvironment);

}  // namespace detail

// The shared context (created on first use, validation as the environment says), or
// nullptr with the reason in `*error`.
inline vk::Context* shared_vk_context(std::string* error = nullptr) {
  auto& s = detail::shared_vk_context_storage();
  if (!s.tried) {
    s.tried = true;
    auto created = vk::Context::create({.app_name = "gauss-tests"});
    if (created) {
      s.context = std::move(*created);
    } else {
      s.error = created.message();
    }
  }
  if (error) *error = s.error;
  return s.context.get();
}

class VkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string error;
    context_ = shared_vk_context(&error);
    ASSERT_NE(context_, nullptr) << "no usable Vulkan device: " << error;
    errors_at_start_ = vk::process_validation_error_count();
    if (const char* expect = std::getenv("GAUSS_EXPECT_SUBGROUP_SIZE"); expect && *expect) {
      if (context_->device_name().find("llvmpipe") == std::string::npos) {
        GTEST_SKIP() << "LP_NATIVE_VECTOR_WIDTH only changes lavapipe's subgroup size; device is "
                     << context_->device_name();
      }
      ASSERT_EQ(context_->subgroup_size(), static_cast<std::uint32_t>(std::atoi(expect)))
          << "GAUSS_EXPECT_SUBGROUP_SIZE: the LP_NATIVE_VECTOR_WIDTH of this variant did not take effect";
    }
  }

  void TearDown() override {
    if (allow_errors_ || context_ == nullptr) return;
    EXPECT_EQ(vk::process_validation_error_count(), errors_at_start_)
        << "Vulkan validation reported errors during this test; last on the shared context: "
        << context_->last_validation_error();
  }

  vk::Context& context() { return *context_; }
  // For tests that trigger validation errors deliberately.
  void allow_validation_errors() { allow_errors_ = true; }

 private:
  vk::Context* context_{nullptr};
  std::uint64_t errors_at_start_{0};
  bool allow_errors_{false};
};

}  // namespace gauss::test
