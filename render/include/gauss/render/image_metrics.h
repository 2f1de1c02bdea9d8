#pragma once
// Image comparison for the renderer: PSNR and maximum absolute error between two RGBA8
// images over the colour channels (alpha is ignored: every renderer output has alpha 255).
#include <cstdint>
#include <limits>

#include "gauss/engine/image_io.h"
#include "gauss/engine/result.h"

namespace gauss::render {

struct ImageDiff {
  double psnr_db{0.0};    // 10 log10(255^2 / mse); +infinity when the images are equal
  double mse{0.0};        // mean squared error in 8-bit units over R, G, B
  int max_abs_error{0};   // largest |a - b| of any R, G or B byte (0..255)
  std::uint64_t pixels{0};          // pixels compared
  std::uint64_t pixels_differing{0};  // pixels with any channel different
};

// Compares rows [row_begin, row_end) (clamped to the height) of two images of equal size.
// Fails, naming both sizes, when the sizes differ or a pixel buffer does not match its
// size, and on an empty row range.
Expected<ImageDiff> compare_images(const ImageRGBA8& a, const ImageRGBA8& b, std::uint32_t row_begin = 0,
                                   std::uint32_t row_end = std::numeric_limits<std::uint32_t>::max());

}  // namespace gauss::render
