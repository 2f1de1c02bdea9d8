#pragma once
// Private to gauss_eval: input checks shared by every metric, and the separable filtering
// that SSIM and FLIP are built on.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gauss/eval/image_metrics.h"

namespace gauss::eval::detail {

// Checks two images and a mask for any metric. Returns the number of counted pixels, or
// an error naming what is wrong: sizes that differ, an empty image, an rgba span shorter
// than width * height * 4, a mask with another count than width * height, or a mask that
// selects no pixel. `what` names the metric in the message ("psnr: ...").
Expected<std::uint64_t> check_inputs(const char* what, const ImageView& a, const ImageView& b,
                                     const Mask& mask);

inline bool counts(const Mask& mask, std::size_t i) { return mask.empty() || mask[i] != 0; }

// How a 1-D filter treats taps that fall outside the image.
enum class Border {
  kClamp,  // the nearest edge pixel is repeated (FLIP's reference does this)
  kSkip,   // the tap is left out of the sum (a zero-padded image; SSIM renormalises)
};

// One pass of a separable filter over a width x height plane (row-major), along x
// (`along_x`) or along y. `kernel` has odd length 2r + 1, centred on its middle tap.
// The taps are summed in order from -r to +r, so the same pixels give the same bits
// whatever the image size around them.
std::vector<double> filter_1d(const std::vector<double>& plane, std::uint32_t width,
                              std::uint32_t height, const std::vector<double>& kernel,
                              bool along_x, Border border);

// filter_1d along x with `kx`, then along y with `ky`.
std::vector<double> filter_2d(const std::vector<double>& plane, std::uint32_t width,
                              std::uint32_t height, const std::vector<double>& kx,
                              const std::vector<double>& ky, Border border);

}  // namespace gauss::eval::detail
