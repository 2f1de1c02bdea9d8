#pragma once
// Golden-image checks, pixel exact (our goldens are exact on lavapipe).
//
//   EXPECT_GOLDEN(image, "compute_pattern");   compares with golden/compute_pattern.png
//   EXPECT_TRUE(gauss::test::images_equal(expected, actual, "name"));  two images in memory
//
// On a mismatch the test fails with the number of differing pixels, the largest channel
// difference and the first differing pixel, and writes <build>/test-output/<name>.actual.png
// and <name>.diff.png (differing pixels magenta, equal ones a dimmed grey copy).
// A golden is never written by a test: a missing golden fails, saying how to create it
// with scripts/approve-goldens, which is the one deliberate way to change goldens.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "gauss/engine/image_io.h"
#include "test_data.h"

namespace gauss::test {

inline std::filesystem::path golden_dir() { return std::filesystem::path(GAUSS_SOURCE_DIR) / "golden"; }

namespace detail {

// Golden names become file names: keep them to [a-z0-9_-].
inline bool valid_golden_name(const std::string& name) {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

inline std::string write_actual(const ImageRGBA8& actual, const std::string& name) {
  const auto path = output_dir() / (name + ".actual.png");
  if (auto st = write_png(path, actual); !st) return "(could not write the actual image: " + st.message() + ")";
  return path.string();
}

inline std::string approve_hint(const std::string& name) {
  return "scripts/approve-goldens --from " + output_dir().string() + " " + name;
}

}  // namespace detail

// Pixel-exact comparison of two images of the same size. `name` names the output files.
inline ::testing::AssertionResult images_equal(const ImageRGBA8& expected, const ImageRGBA8& actual,
                                               const std::string& name) {
  if (!detail::valid_golden_name(name)) {
    return ::testing::AssertionFailure() << "image name '" << name << "' must be non-empty [a-z0-9_-]";
  }
  const std::size_t expected_bytes = std::size_t{expected.width} * expected.height * 4;
  const std::size_t actual_bytes = std::size_t{actual.width} * actual.height * 4;
  if (expected.pixels.size() != expected_bytes || actual.pixels.size() != actual_bytes) {
    return ::testing::AssertionFailure() << name << ": an image's pixel buffer does not match its size";
  }
  if (expected.width != actual.width || expected.height != actual.height) {
    const std::string written = detail::write_actual(actual, name);
    return ::testing::AssertionFailure() << name << ": size " << actual.width << "x" << actual.height << " but expected "
                                         << expected.width << "x" << expected.height << "; actual image: " << written;
  }
  std::size_t differing = 0;
  int max_diff = 0;
  std::size_t first = actual_bytes;
  ImageRGBA8 diff{actual.width, actual.height, std::vector<std::uint8_t>(actual_bytes)};
  for (std::size_t p = 0; p < actual_bytes; p += 4) {
    int pixel_diff = 0;
    for (int c = 0; c < 4; ++c) pixel_diff = std::max(pixel_diff, std::abs(int{expected.pixels[p + c]} - int{actual.pixels[p + c]}));
    if (pixel_diff > 0) {
      ++differing;
      if (first == actual_bytes) first = p;
      max_diff = std::max(max_diff, pixel_diff);
      diff.pixels[p + 0] = 255;
      diff.pixels[p + 1] = 0;
      diff.pixels[p + 2] = 255;
    } else {
      const auto grey = static_cast<std::uint8_t>(
          (int{actual.pixels[p]} + int{actual.pixels[p + 1]} + int{actual.pixels[p + 2]}) / 9);
      diff.pixels[p + 0] = diff.pixels[p + 1] = diff.pixels[p + 2] = grey;
    }
    diff.pixels[p + 3] = 255;
  }
  if (differing == 0) return ::testing::AssertionSuccess();
  const std::string written = detail::write_actual(actual, name);
  const auto diff_path = output_dir() / (name + ".diff.png");
  const auto diff_status = write_png(diff_path, diff);
  const std::size_t fx = (first / 4) % actual.width;
  const std::size_t fy = (first / 4) / actual.width;
  auto px = [&](const ImageRGBA8& im) {
    return std::to_string(im.pixels[first]) + "," + std::to_string(im.pixels[first + 1]) + "," +
           std::to_string(im.pixels[first + 2]) + "," + std::to_string(im.pixels[first + 3]);
  };
  return ::testing::AssertionFailure()
         << name << ": " << differing << " of " << std::size_t{actual.width} * actual.height
         << " pixels differ, max channel difference " << max_diff << "; first at (" << fx << ", " << fy
         << "): expected " << px(expected) << " actual " << px(actual) << "; actual image: " << written
         << ", diff: " << (diff_status ? diff_path.string() : "(not written: " + diff_status.message() + ")");
}

// Compares with golden/<name>.png. Fails when the golden is missing or unreadable.
inline ::testing::AssertionResult matches_golden(const ImageRGBA8& actual, const std::string& name) {
  if (!detail::valid_golden_name(name)) {
    return ::testing::AssertionFailure() << "golden name '" << name << "' must be non-empty [a-z0-9_-]";
  }
  const auto golden_path = golden_dir() / (name + ".png");
  if (!std::filesystem::exists(golden_path)) {
    const std::string written = detail::write_actual(actual, name);
    return ::testing::AssertionFailure() << "golden " << golden_path.string() << " does not exist. This run's image is "
                                         << written << "; look at it, and if it is right create the golden with: "
                                         << detail::approve_hint(name);
  }
  auto golden = read_png_rgba8(golden_path);
  if (!golden) return ::testing::AssertionFailure() << "golden " << golden_path.string() << ": " << golden.message();
  auto result = images_equal(*golden, actual, name);
  if (!result) {
    return ::testing::AssertionFailure() << result.message() << ". If the change is intended, approve it with: "
                                         << detail::approve_hint(name);
  }
  return result;
}

}  // namespace gauss::test

#define EXPECT_GOLDEN(image, name) EXPECT_TRUE(::gauss::test::matches_golden((image), (name)))
#define ASSERT_GOLDEN(image, name) ASSERT_TRUE(::gauss::test::matches_golden((image), (name)))
