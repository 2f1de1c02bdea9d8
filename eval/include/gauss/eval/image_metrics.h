#pragma once
// Image comparison metrics for gauss-eval, each over a mask of pixels that count (pixels
// without valid ground-truth depth, or outside what both images cover, are left out).
//   PSNR  on linear 8-bit RGB values, 10 log10(255^2 / MSE) over the masked pixels; +inf
//         for identical images (reported as such, never as a large number).
//   SSIM  Wang et al. 2004 on luma (Rec. 601), 11x11 Gaussian window (sigma 1.5), K1 0.01,
//         K2 0.03, L 255; the mean of the SSIM map over masked window centres.
//   FLIP  the LDR ꟻLIP of Andersson et al. 2020 (no learned weights): colour pipeline in
//         YyCxCz with CSF filtering, Hunt-adjusted L*a*b* HyAB distance, feature (edge and
//         point) differences, combined per pixel; the mean over masked pixels, in [0, 1].
//         Viewing conditions: 0.7 m from a 0.7 m wide monitor of 3840 px (67 px/degree),
//         the reference implementation's defaults.
// LPIPS is not provided: it needs learned network weights that this project cannot obtain.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss::eval {

// An RGBA8 image (alpha ignored by every metric).
struct ImageView {
  std::uint32_t width{0}, height{0};
  std::span<const std::uint8_t> rgba;  // width * height * 4
};

// 1 = the pixel counts (any non-zero value counts). Empty = every pixel counts. What each
// metric does with it is written beside its implementation (eval/src/); in short, a pixel
// outside the mask never changes any metric: PSNR skips it, SSIM's windows renormalise
// their Gaussian weights over the counted pixels, FLIP replaces it by a nearby counted pixel
// before filtering (as the reference does beyond the image border). A rectangular mask
// gives the metrics of the cropped images.
using Mask = std::vector<std::uint8_t>;

struct ImageScores {
  double psnr_db{0.0};   // +inf when the masked pixels are identical
  double ssim{0.0};
  double flip{0.0};
  std::uint64_t pixels{0};          // masked pixels compared
  std::uint64_t differing_pixels{0};  // masked pixels whose RGB differs at all
};

// Errors: sizes differ, a span shorter than width*height*4, a mask of the wrong size, or
// no pixel in the mask.
Expected<double> psnr(const ImageView& a, const ImageView& b, const Mask& mask = {});
// The mean absolute difference of the RGB values (0..255) over the masked pixels: the
// flicker between consecutive frames of a settled view.
Expected<double> mean_abs_difference(const ImageView& a, const ImageView& b, const Mask& mask = {});
Expected<double> ssim(const ImageView& a, const ImageView& b, const Mask& mask = {});

// Flicker of a settled view: each frame's mean_abs_difference from the one before.
class FrameChange {
 public:
  // Errors: a frame of another size than the first (as mean_abs_difference).
  Status add(const ImageView& frame);
  double mean() const { return pairs_ ? sum_ / static_cast<double>(pairs_) : 0.0; }
  double max() const { return max_; }
  std::uint64_t pairs() const { return pairs_; }

 private:
  std::vector<std::uint8_t> prev_;
  std::uint32_t width_{0}, height_{0};
  double sum_{0.0}, max_{0.0};
  std::uint64_t pairs_{0};
};
Expected<double> flip(const ImageView& reference, const ImageView& test, const Mask& mask = {});
Expected<ImageScores> compare(const ImageView& reference, const ImageView& test, const Mask& mask = {});

// Per-pixel SSIM map (row-major); pixels outside the mask hold 0, ssim() is the mean of
// the others.
Expected<std::vector<float>> ssim_map(const ImageView& a, const ImageView& b,
                                      const Mask& mask = {});

// Per-pixel FLIP error map in [0, 1] (row-major), for difference images in reports.
Expected<std::vector<float>> flip_map(const ImageView& reference, const ImageView& test);
// The same over a mask: pixels outside it hold 0; flip() is the mean of the others.
Expected<std::vector<float>> flip_map(const ImageView& reference, const ImageView& test,
                                      const Mask& mask);

}  // namespace gauss::eval
