#include "gauss/render/image_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

namespace gauss::render {
namespace {

std::string size_of(const ImageRGBA8& im) {
  return std::to_string(im.width) + "x" + std::to_string(im.height) + " (" + std::to_string(im.pixels.size()) +
         " bytes)";
}

bool consistent(const ImageRGBA8& im) { return im.pixels.size() == std::size_t(im.width) * im.height * 4; }

}  // namespace

Expected<ImageDiff> compare_images(const ImageRGBA8& a, const ImageRGBA8& b, std::uint32_t row_begin,
                                   std::uint32_t row_end) {
  if (!consistent(a) || !consistent(b) || a.width != b.width || a.height != b.height)
    return Error{"compare_images: images differ in size or are inconsistent: " + size_of(a) + " vs " + size_of(b)};
  row_end = std::min(row_end, a.height);
  if (row_begin >= row_end || a.width == 0)
    return Error{"compare_images: empty region (rows " + std::to_string(row_begin) + ".." + std::to_string(row_end) +
                 " of " + size_of(a) + ")"};
  ImageDiff d;
  double sum_sq = 0.0;
  for (std::size_t px = std::size_t(row_begin) * a.width; px < std::size_t(row_end) * a.width; ++px) {
    bool differs = false;
    for (int c = 0; c < 3; ++c) {
      const int e = std::abs(int(a.pixels[px * 4 + c]) - int(b.pixels[px * 4 + c]));
      sum_sq += double(e) * e;
      d.max_abs_error = std::max(d.max_abs_error, e);
      differs = differs || e != 0;
    }
    d.pixels_differing += differs ? 1 : 0;
    ++d.pixels;
  }
  d.mse = sum_sq / (3.0 * double(d.pixels));
  d.psnr_db = d.mse == 0.0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(255.0 * 255.0 / d.mse);
  return d;
}

}  // namespace gauss::render
