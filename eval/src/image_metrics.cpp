// PSNR and SSIM over a mask, the input checks every metric shares, and compare().
// FLIP is in flip.cpp.
#include <cmath>
#include <limits>
#include <string>

#include "gauss/eval/image_metrics.h"
#include "metric_support.h"

namespace gauss::eval {
namespace detail {

namespace {

std::string dims(const ImageView& v) {
  return std::to_string(v.width) + "x" + std::to_string(v.height);
}

}  // namespace

Expected<std::uint64_t> check_inputs(const char* what, const ImageView& a, const ImageView& b,
                                     const Mask& mask) {
  const std::string prefix = std::string(what) + ": ";
  if (a.width != b.width || a.height != b.height)
    return Error{prefix + "image sizes differ: " + dims(a) + " and " + dims(b)};
  const std::uint64_t pixels = std::uint64_t{a.width} * a.height;
  if (pixels == 0) return Error{prefix + "empty image (" + dims(a) + ")"};
  const std::uint64_t bytes = pixels * 4;
  if (a.rgba.size() < bytes)
    return Error{prefix + "first image holds " + std::to_string(a.rgba.size()) + " bytes, " +
                 dims(a) + " RGBA8 needs " + std::to_string(bytes)};
  if (b.rgba.size() < bytes)
    return Error{prefix + "second image holds " + std::to_string(b.rgba.size()) + " bytes, " +
                 dims(b) + " RGBA8 needs " + std::to_string(bytes)};
  if (mask.empty()) return pixels;
  if (mask.size() != pixels)
    return Error{prefix + "mask has " + std::to_string(mask.size()) + " entries, a " + dims(a) +
                 " image needs " + std::to_string(pixels)};
  std::uint64_t counted = 0;
  for (std::uint8_t m : mask) counted += m != 0 ? 1 : 0;
  if (counted == 0) return Error{prefix + "the mask selects no pixel"};
  return counted;
}

std::vector<double> filter_1d(const std::vector<double>& plane, std::uint32_t width,
                              std::uint32_t height, const std::vector<double>& kernel,
                              bool along_x, Border border) {
  // Each output pixel sums kernel[0] * p[-r] + ... + kernel[2r] * p[+r] in that order,
  // whichever pass; a skipped tap adds an exact 0. The loops run over whole rows, so the
  // compiler can vectorise them.
  const std::size_t r = kernel.size() / 2;
  const std::size_t w = width, h = height;
  std::vector<double> out(plane.size(), 0.0);
  if (along_x) {
    std::vector<double> line(w + 2 * r);
    for (std::size_t y = 0; y < h; ++y) {
      const double* row = plane.data() + y * w;
      const double left = border == Border::kClamp ? row[0] : 0.0;
      const double right = border == Border::kClamp ? row[w - 1] : 0.0;
      for (std::size_t i = 0; i < r; ++i) {
        line[i] = left;
        line[r + w + i] = right;
      }
      for (std::size_t x = 0; x < w; ++x) line[r + x] = row[x];
      double* dst = out.data() + y * w;
      for (std::size_t k = 0; k < kernel.size(); ++k) {
        const double kk = kernel[k];
        const double* src = line.data() + k;
        for (std::size_t x = 0; x < w; ++x) dst[x] += kk * src[x];
      }
    }
    return out;
  }
  for (std::size_t y = 0; y < h; ++y) {
    double* dst = out.data() + y * w;
    for (std::size_t k = 0; k < kernel.size(); ++k) {
      const long at = static_cast<long>(y + k) - static_cast<long>(r);
      long row = at;
      if (at < 0 || at >= static_cast<long>(h)) {
        if (border == Border::kSkip) continue;
        row = at < 0 ? 0 : static_cast<long>(h) - 1;
      }
      const double kk = kernel[k];
      const double* src = plane.data() + static_cast<std::size_t>(row) * w;
      for (std::size_t x = 0; x < w; ++x) dst[x] += kk * src[x];
    }
  }
  return out;
}

std::vector<double> filter_2d(const std::vector<double>& plane, std::uint32_t width,
                              std::uint32_t height, const std::vector<double>& kx,
                              const std::vector<double>& ky, Border border) {
  return filter_1d(filter_1d(plane, width, height, kx, true, border), width, height, ky, false,
                   border);
}

}  // namespace detail

using detail::counts;

// PSNR: every channel of every masked pixel counts once; pixels outside the mask are not
// read at all.
Expected<double> psnr(const ImageView& a, const ImageView& b, const Mask& mask) {
  auto counted = detail::check_inputs("psnr", a, b, mask);
  if (!counted) return counted.error();
  const std::size_t pixels = std::size_t{a.width} * a.height;
  std::uint64_t squared = 0;  // exact: at most 2^32 pixels * 3 * 255^2 < 2^64
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!counts(mask, i)) continue;
    for (std::size_t c = 0; c < 3; ++c) {
      const int d = int{a.rgba[i * 4 + c]} - int{b.rgba[i * 4 + c]};
      squared += static_cast<std::uint64_t>(d * d);
    }
  }
  if (squared == 0) return std::numeric_limits<double>::infinity();
  const double mse = static_cast<double>(squared) / (3.0 * static_cast<double>(*counted));
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

Expected<double> mean_abs_difference(const ImageView& a, const ImageView& b, const Mask& mask) {
  auto counted = detail::check_inputs("mean_abs_difference", a, b, mask);
  if (!counted) return counted.error();
  const std::size_t pixels = std::size_t{a.width} * a.height;
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!counts(mask, i)) continue;
    for (std::size_t c = 0; c < 3; ++c) sum += static_cast<std::uint64_t>(std::abs(int{a.rgba[i * 4 + c]} - int{b.rgba[i * 4 + c]}));
  }
  return static_cast<double>(sum) / (3.0 * static_cast<double>(*counted));
}

Status FrameChange::add(const ImageView& frame) {
  if (!prev_.empty()) {
    auto d = mean_abs_difference({width_, height_, prev_}, frame);
    if (!d) return d.error();
    sum_ += *d;
    max_ = std::max(max_, *d);
    ++pairs_;
  }
  prev_.assign(frame.rgba.begin(), frame.rgba.end());
  width_ = frame.width;
  height_ = frame.height;
  return Ok{};
}

namespace {

// Rec. 601 luma of pixel i, in [0, 255].
double luma(const ImageView& v, std::size_t i) {
  return 0.299 * v.rgba[i * 4 + 0] + 0.587 * v.rgba[i * 4 + 1] + 0.114 * v.rgba[i * 4 + 2];
}

// Wang et al. 2004's window: an 11-tap Gaussian with sigma 1.5 along each axis (its 2-D
// product is their 11x11 window). Unnormalised: SSIM divides by the summed weights.
std::vector<double> ssim_window() {
  std::vector<double> k(11);
  for (int i = -5; i <= 5; ++i)
    k[static_cast<std::size_t>(i + 5)] = std::exp(-(i * i) / (2.0 * 1.5 * 1.5));
  return k;
}

}  // namespace

// SSIM (Wang, Bovik, Sheikh, Simoncelli 2004, Eq. 13 with the Gaussian-weighted local
// statistics of their Eqs. 14-16), on Rec. 601 luma with L = 255, K1 = 0.01, K2 = 0.03.
// Mask: the local means, variances and covariance at a window centre are taken over the
// counted pixels of the 11x11 window only, with the Gaussian weights renormalised over
// them (a normalised convolution; the image border is treated the same way, as pixels that
// do not count). Inside a full mask, away from the border, this is exactly Wang's window.
// The result is the mean of the SSIM map over the window centres that count. So a pixel
// outside the mask changes neither any window's statistics nor the mean, and a rectangular
// mask gives the SSIM of the cropped images.
namespace {

// The SSIM map over counted window centres (0 elsewhere); inputs already checked.
std::vector<double> ssim_values(const ImageView& a, const ImageView& b, const Mask& mask) {
  const std::uint32_t w = a.width, h = a.height;
  const std::size_t pixels = std::size_t{w} * h;
  // Weighted moments: m, m x, m y, m x^2, m y^2, m x y with m = 1 for counted pixels.
  std::vector<double> m(pixels), mx(pixels), my(pixels), mxx(pixels), myy(pixels), mxy(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!counts(mask, i)) continue;  // left at 0: the pixel's value is never read
    const double x = luma(a, i), y = luma(b, i);
    m[i] = 1.0;
    mx[i] = x;
    my[i] = y;
    mxx[i] = x * x;
    myy[i] = y * y;
    mxy[i] = x * y;
  }
  const std::vector<double> k = ssim_window();
  const auto blur = [&](const std::vector<double>& p) {
    return detail::filter_2d(p, w, h, k, k, detail::Border::kSkip);
  };
  const std::vector<double> sw = blur(m), sx = blur(mx), sy = blur(my), sxx = blur(mxx),
                            syy = blur(myy), sxy = blur(mxy);
  const double c1 = (0.01 * 255.0) * (0.01 * 255.0);
  const double c2 = (0.03 * 255.0) * (0.03 * 255.0);
  std::vector<double> out(pixels, 0.0);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!counts(mask, i)) continue;
    // sw[i] > 0: the centre itself counts and has the largest weight.
    const double mu_x = sx[i] / sw[i], mu_y = sy[i] / sw[i];
    const double var_x = sxx[i] / sw[i] - mu_x * mu_x;
    const double var_y = syy[i] / sw[i] - mu_y * mu_y;
    const double cov = sxy[i] / sw[i] - mu_x * mu_y;
    out[i] = ((2.0 * mu_x * mu_y + c1) * (2.0 * cov + c2)) /
             ((mu_x * mu_x + mu_y * mu_y + c1) * (var_x + var_y + c2));
  }
  return out;
}

}  // namespace

Expected<double> ssim(const ImageView& a, const ImageView& b, const Mask& mask) {
  auto counted = detail::check_inputs("ssim", a, b, mask);
  if (!counted) return counted.error();
  const std::vector<double> map = ssim_values(a, b, mask);
  double sum = 0.0;
  for (std::size_t i = 0; i < map.size(); ++i)
    if (counts(mask, i)) sum += map[i];
  return sum / static_cast<double>(*counted);
}

Expected<std::vector<float>> ssim_map(const ImageView& a, const ImageView& b, const Mask& mask) {
  auto counted = detail::check_inputs("ssim_map", a, b, mask);
  if (!counted) return counted.error();
  const std::vector<double> map = ssim_values(a, b, mask);
  return std::vector<float>(map.begin(), map.end());
}

Expected<ImageScores> compare(const ImageView& reference, const ImageView& test, const Mask& mask) {
  auto counted = detail::check_inputs("compare", reference, test, mask);
  if (!counted) return counted.error();
  ImageScores s;
  s.pixels = *counted;
  const std::size_t pixels = std::size_t{reference.width} * reference.height;
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!counts(mask, i)) continue;
    const std::size_t o = i * 4;
    if (reference.rgba[o] != test.rgba[o] || reference.rgba[o + 1] != test.rgba[o + 1] ||
        reference.rgba[o + 2] != test.rgba[o + 2])
      ++s.differing_pixels;
  }
  auto p = psnr(reference, test, mask);
  if (!p) return p.error();
  auto q = ssim(reference, test, mask);
  if (!q) return q.error();
  auto f = flip(reference, test, mask);
  if (!f) return f.error();
  s.psnr_db = *p;
  s.ssim = *q;
  s.flip = *f;
  return s;
}

}  // namespace gauss::eval
