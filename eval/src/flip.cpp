// LDR FLIP (Andersson, Nilsson, Akenine-Moeller, Oskarsson, Astrom, Fairchild: "FLIP: A
// Difference Evaluator for Alternating Images", HPG 2020), written from the paper's
// equations; the constants are those of the paper and of NVlabs' reference code. Each step
// below names the equation it implements (quoted by content, with the paper's symbols).
//
// Colour pipeline: sRGB -> linear RGB -> XYZ -> YyCxCz (the linearised L*a*b* opponent
// space); each channel filtered by its contrast sensitivity function (CSF) in the spatial
// domain; back to linear RGB and clamped to [0, 1]; CIE L*a*b* with the Hunt adjustment;
// HyAB distance; power qc and redistribution to [0, 1] (Delta E_c).
// Feature pipeline: edge (first Gaussian derivative) and point (second derivative)
// detectors on the achromatic channel; the larger normalised difference in feature
// magnitude, to the power qf (Delta E_f).
// Final: Delta E = Delta E_c ^ (1 - Delta E_f) per pixel.
//
// Mask: before any filtering, each pixel outside the mask takes the colour of a masked
// pixel chosen from the mask alone (the nearest masked pixel in its row, else the nearest
// such filled row in its column; ties go left / up), in both images. This extends the
// reference's border rule (the image's edge pixels are repeated) to the mask's edge: a
// pixel outside the mask is never read, a rectangular mask gives exactly the FLIP of the
// cropped images, and a full mask gives the reference's FLIP. The mean is taken over the
// masked pixels.
//
// The reference filters with 2-D kernels; here every kernel is applied as the exact
// product of two 1-D passes (the CSF's blue-yellow kernel, a sum of two Gaussians, as two
// separable terms), in double precision.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "gauss/eval/image_metrics.h"
#include "metric_support.h"

namespace gauss::eval {
namespace {

using detail::Border;
using Vec3 = std::array<double, 3>;

// Viewing conditions (the header's): 0.7 m from a 0.7 m wide, 3840 px wide monitor.
// Pixels per degree = distance * (pixels / width) * pi / 180 = 67.02.
constexpr double kPixelsPerDegree = 0.7 * (3840.0 / 0.7) * std::numbers::pi / 180.0;

// Exponents and redistribution (the paper's values): colour difference exponent qc,
// feature exponent qf, and the error redistribution breakpoints pc, pt.
constexpr double kQc = 0.7;
constexpr double kQf = 0.5;
constexpr double kPc = 0.4;
constexpr double kPt = 0.95;
// Peak-to-trough width of the human edge detector, in degrees (2 standard deviations).
constexpr double kFeatureWidthDeg = 0.082;

// CSF of each opponent channel as a sum of Gaussians in frequency,
//   S(f) = a1 exp(-b1 f^2) + a2 exp(-b2 f^2),
// whose spatial-domain form is s(x) = sum_i a_i sqrt(pi / b_i) exp(-pi^2 x^2 / b_i)
// (x in degrees). The achromatic and red-green CSFs have one term (a2 = 0).
struct Csf {
  double a1, b1, a2, b2;
};
constexpr Csf kCsfAchromatic{1.0, 0.0047, 0.0, 1e-5};
constexpr Csf kCsfRedGreen{1.0, 0.0053, 0.0, 1e-5};
constexpr Csf kCsfBlueYellow{34.1, 0.04, 13.5, 0.025};
// The kernels' radius covers 3 standard deviations of the widest Gaussian (b = 0.04):
// ceil(3 sqrt(b_max / (2 pi^2)) ppd) = 10 px at 67 ppd.
constexpr double kCsfMaxB = 0.04;

// D65 reference white in XYZ (Y = 1).
constexpr Vec3 kWhite{0.950428545, 1.0, 1.088900371};

// Linear sRGB <-> XYZ (D65); the second matrix is the inverse of the first.
constexpr double kRgbToXyz[3][3] = {
    {10135552.0 / 24577794.0, 8788810.0 / 24577794.0, 4435075.0 / 24577794.0},
    {2613072.0 / 12288897.0, 8788810.0 / 12288897.0, 887015.0 / 12288897.0},
    {1425312.0 / 73733382.0, 8788810.0 / 73733382.0, 70074185.0 / 73733382.0}};
constexpr double kXyzToRgb[3][3] = {{3.241003275, -1.537398934, -0.498615861},
                                    {-0.969224334, 1.875930071, 0.041554224},
                                    {0.055639423, -0.204011202, 1.057148933}};

Vec3 mul(const double m[3][3], const Vec3& v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
          m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

double srgb_to_linear(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// XYZ -> YyCxCz: Yy = 116 Y/Yn - 16, Cx = 500 (X/Xn - Y/Yn), Cz = 200 (Y/Yn - Z/Zn).
Vec3 xyz_to_ycxcz(const Vec3& xyz) {
  const double x = xyz[0] / kWhite[0], y = xyz[1] / kWhite[1], z = xyz[2] / kWhite[2];
  return {116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)};
}

Vec3 ycxcz_to_xyz(const Vec3& c) {
  const double y = (c[0] + 16.0) / 116.0;
  return {(y + c[1] / 500.0) * kWhite[0], y * kWhite[1], (y - c[2] / 200.0) * kWhite[2]};
}

// CIE 1976 L*a*b* from XYZ (D65), then the Hunt adjustment a*_H = 0.01 L* a*,
// b*_H = 0.01 L* b* (chroma is less visible at low luminance).
Vec3 xyz_to_hunt_lab(const Vec3& xyz) {
  constexpr double delta = 6.0 / 29.0;
  const auto f = [](double t) {
    return t > delta * delta * delta ? std::cbrt(t) : t / (3.0 * delta * delta) + 4.0 / 29.0;
  };
  const double fx = f(xyz[0] / kWhite[0]), fy = f(xyz[1] / kWhite[1]), fz = f(xyz[2] / kWhite[2]);
  const double l = 116.0 * fy - 16.0;
  return {l, 0.01 * l * 500.0 * (fx - fy), 0.01 * l * 200.0 * (fy - fz)};
}

// HyAB distance: |Delta L| + sqrt(Delta a^2 + Delta b^2).
double hyab(const Vec3& p, const Vec3& q) {
  const double da = p[1] - q[1], db = p[2] - q[2];
  return std::abs(p[0] - q[0]) + std::sqrt(da * da + db * db);
}

// c_max: the largest colour difference, between Hunt-adjusted pure green and pure blue,
// to the power qc.
double colour_max() {
  const Vec3 green = xyz_to_hunt_lab(mul(kRgbToXyz, Vec3{0.0, 1.0, 0.0}));
  const Vec3 blue = xyz_to_hunt_lab(mul(kRgbToXyz, Vec3{0.0, 0.0, 1.0}));
  return std::pow(hyab(green, blue), kQc);
}

// Error redistribution: differences below pc * c_max map linearly to [0, pt], the rest
// to (pt, 1].
double redistribute(double e, double cmax) {
  const double pccmax = kPc * cmax;
  return e < pccmax ? (kPt / pccmax) * e : kPt + ((e - pccmax) / (cmax - pccmax)) * (1.0 - kPt);
}

// One Gaussian of a spatial-domain CSF along one axis, exp(-pi^2 (k / ppd)^2 / b),
// unnormalised.
std::vector<double> csf_gaussian(double b, int radius) {
  std::vector<double> k(static_cast<std::size_t>(2 * radius + 1));
  for (int i = -radius; i <= radius; ++i) {
    const double x = i / kPixelsPerDegree;
    k[static_cast<std::size_t>(i + radius)] =
        std::exp(-std::numbers::pi * std::numbers::pi * x * x / b);
  }
  return k;
}

double sum(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return s;
}

std::vector<double> scaled(std::vector<double> v, double f) {
  for (double& x : v) x *= f;
  return v;
}

int csf_radius() {
  return static_cast<int>(std::ceil(
      3.0 * std::sqrt(kCsfMaxB / (2.0 * std::numbers::pi * std::numbers::pi)) * kPixelsPerDegree));
}

// Filters a plane with a CSF's normalised 2-D kernel s(x) s(y) / sum, as a weighted sum of
// separable passes: term i is c_i G_i(x) G_i(y) with c_i = a_i sqrt(pi / b_i), and its
// share of the kernel's total is c_i S_i^2 / sum_j c_j S_j^2 (S_i = sum of G_i).
std::vector<double> csf_filter(const std::vector<double>& plane, std::uint32_t w, std::uint32_t h,
                               const Csf& csf) {
  const int r = csf_radius();
  const std::vector<double> g1 = csf_gaussian(csf.b1, r);
  const std::vector<double> n1 = scaled(g1, 1.0 / sum(g1));
  if (csf.a2 == 0.0) return detail::filter_2d(plane, w, h, n1, n1, Border::kClamp);
  const std::vector<double> g2 = csf_gaussian(csf.b2, r);
  const std::vector<double> n2 = scaled(g2, 1.0 / sum(g2));
  const double t1 = csf.a1 * std::sqrt(std::numbers::pi / csf.b1) * sum(g1) * sum(g1);
  const double t2 = csf.a2 * std::sqrt(std::numbers::pi / csf.b2) * sum(g2) * sum(g2);
  const std::vector<double> f1 = detail::filter_2d(plane, w, h, n1, n1, Border::kClamp);
  const std::vector<double> f2 = detail::filter_2d(plane, w, h, n2, n2, Border::kClamp);
  std::vector<double> out(plane.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = (t1 * f1[i] + t2 * f2[i]) / (t1 + t2);
  return out;
}

// The feature detectors' 1-D factors: with sigma = 0.5 w ppd and radius ceil(3 sigma), the
// Gaussian g(k) = exp(-k^2 / (2 sigma^2)) normalised to sum 1; its first derivative
// -k g(k) and second derivative (k^2 / sigma^2 - 1) g(k) normalised so that the positive
// weights sum to 1 and the negative ones to -1. The 2-D edge detector along x is
// edge(x) g(y) (and its transpose along y); the point detector likewise.
struct FeatureKernels {
  std::vector<double> gauss, edge, point;
};

FeatureKernels feature_kernels() {
  const double sigma = 0.5 * kFeatureWidthDeg * kPixelsPerDegree;
  const int r = static_cast<int>(std::ceil(3.0 * sigma));
  FeatureKernels k;
  const auto n = static_cast<std::size_t>(2 * r + 1);
  k.gauss.resize(n);
  k.edge.resize(n);
  k.point.resize(n);
  double edge_pos = 0.0, edge_neg = 0.0, point_pos = 0.0, point_neg = 0.0;
  for (int i = -r; i <= r; ++i) {
    const auto j = static_cast<std::size_t>(i + r);
    const double g = std::exp(-(i * i) / (2.0 * sigma * sigma));
    k.gauss[j] = g;
    k.edge[j] = -i * g;
    k.point[j] = (i * i / (sigma * sigma) - 1.0) * g;
    (k.edge[j] > 0.0 ? edge_pos : edge_neg) += std::abs(k.edge[j]);
    (k.point[j] > 0.0 ? point_pos : point_neg) += std::abs(k.point[j]);
  }
  const double gauss_sum = sum(k.gauss);
  for (std::size_t j = 0; j < n; ++j) {
    k.gauss[j] /= gauss_sum;
    k.edge[j] /= k.edge[j] > 0.0 ? edge_pos : edge_neg;
    k.point[j] /= k.point[j] > 0.0 ? point_pos : point_neg;
  }
  return k;
}

// For each pixel, the pixel whose colour it takes before filtering (see the file comment).
std::vector<std::size_t> fill_sources(const Mask& mask, std::uint32_t w, std::uint32_t h) {
  const std::size_t n = std::size_t{w} * h;
  std::vector<std::size_t> src(n);
  for (std::size_t i = 0; i < n; ++i) src[i] = i;
  if (mask.empty()) return src;
  // Along rows: the nearest masked pixel of the row (ties to the left).
  std::vector<bool> row_filled(h, false);
  std::vector<long> left(w), right(w);
  for (std::uint32_t y = 0; y < h; ++y) {
    const std::size_t row = std::size_t{y} * w;
    long last = -1;
    for (std::uint32_t x = 0; x < w; ++x) {
      if (mask[row + x] != 0) last = x;
      left[x] = last;
    }
    last = -1;
    for (std::uint32_t x = w; x-- > 0;) {
      if (mask[row + x] != 0) last = x;
      right[x] = last;
    }
    if (left[w - 1] < 0) continue;  // no masked pixel in this row
    row_filled[y] = true;
    for (std::uint32_t x = 0; x < w; ++x) {
      const long l = left[x], r = right[x], xx = x;
      const long pick = l < 0 ? r : r < 0 ? l : (xx - l <= r - xx ? l : r);
      src[row + x] = row + static_cast<std::size_t>(pick);
    }
  }
  // Along columns: rows without a masked pixel copy the nearest filled row (ties up).
  // check_inputs guarantees at least one filled row.
  std::vector<long> up(h), down(h);
  long last = -1;
  for (std::uint32_t y = 0; y < h; ++y) {
    if (row_filled[y]) last = y;
    up[y] = last;
  }
  last = -1;
  for (std::uint32_t y = h; y-- > 0;) {
    if (row_filled[y]) last = y;
    down[y] = last;
  }
  for (std::uint32_t y = 0; y < h; ++y) {
    if (row_filled[y]) continue;
    const long u = up[y], d = down[y], yy = y;
    const long pick = u < 0 ? d : d < 0 ? u : (yy - u <= d - yy ? u : d);
    for (std::uint32_t x = 0; x < w; ++x)
      src[std::size_t{y} * w + x] = src[static_cast<std::size_t>(pick) * w + x];
  }
  return src;
}

// One image in YyCxCz (three planes) and its achromatic feature channel: (Yy + 16) / 116,
// which is the white-normalised luminance Y / Yn in [0, 1].
struct Opponent {
  std::vector<double> yy, cx, cz, luminance;
};

Opponent to_opponent(const ImageView& v, const std::vector<std::size_t>& src) {
  Opponent o;
  const std::size_t n = src.size();
  o.yy.resize(n);
  o.cx.resize(n);
  o.cz.resize(n);
  o.luminance.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t p = src[i] * 4;
    const Vec3 lin{srgb_to_linear(v.rgba[p] / 255.0), srgb_to_linear(v.rgba[p + 1] / 255.0),
                   srgb_to_linear(v.rgba[p + 2] / 255.0)};
    const Vec3 xyz = mul(kRgbToXyz, lin);
    const Vec3 c = xyz_to_ycxcz(xyz);
    o.yy[i] = c[0];
    o.cx[i] = c[1];
    o.cz[i] = c[2];
    o.luminance[i] = (c[0] + 16.0) / 116.0;
  }
  return o;
}

// CSF-filtered colour, clamped to the linear RGB cube, in Hunt-adjusted L*a*b*.
std::vector<Vec3> filtered_colour(const Opponent& o, std::uint32_t w, std::uint32_t h) {
  const std::vector<double> yy = csf_filter(o.yy, w, h, kCsfAchromatic);
  const std::vector<double> cx = csf_filter(o.cx, w, h, kCsfRedGreen);
  const std::vector<double> cz = csf_filter(o.cz, w, h, kCsfBlueYellow);
  std::vector<Vec3> out(yy.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    Vec3 rgb = mul(kXyzToRgb, ycxcz_to_xyz({yy[i], cx[i], cz[i]}));
    for (double& c : rgb) c = std::clamp(c, 0.0, 1.0);
    out[i] = xyz_to_hunt_lab(mul(kRgbToXyz, rgb));
  }
  return out;
}

// Edge and point feature magnitudes: |(edge_x, edge_y)| and |(point_x, point_y)|.
struct Features {
  std::vector<double> edge, point;
};

Features features(const std::vector<double>& lum, std::uint32_t w, std::uint32_t h,
                  const FeatureKernels& k) {
  using detail::filter_1d;
  const std::vector<double> gx = filter_1d(lum, w, h, k.gauss, true, Border::kClamp);
  const std::vector<double> ex = filter_1d(filter_1d(lum, w, h, k.edge, true, Border::kClamp), w,
                                           h, k.gauss, false, Border::kClamp);
  const std::vector<double> px = filter_1d(filter_1d(lum, w, h, k.point, true, Border::kClamp), w,
                                           h, k.gauss, false, Border::kClamp);
  const std::vector<double> ey = filter_1d(gx, w, h, k.edge, false, Border::kClamp);
  const std::vector<double> py = filter_1d(gx, w, h, k.point, false, Border::kClamp);
  Features f;
  f.edge.resize(lum.size());
  f.point.resize(lum.size());
  for (std::size_t i = 0; i < lum.size(); ++i) {
    f.edge[i] = std::hypot(ex[i], ey[i]);
    f.point[i] = std::hypot(px[i], py[i]);
  }
  return f;
}

// The per-pixel FLIP map over every pixel (pixels outside the mask hold the error of their
// filled-in colours; callers ignore them).
std::vector<double> flip_pixels(const ImageView& reference, const ImageView& test,
                                const Mask& mask) {
  const std::uint32_t w = reference.width, h = reference.height;
  const std::vector<std::size_t> src = fill_sources(mask, w, h);
  const Opponent ref = to_opponent(reference, src);
  const Opponent tst = to_opponent(test, src);

  // Colour: Delta E_c = redistribute(HyAB(ref, test)^qc).
  const double cmax = colour_max();
  const std::vector<Vec3> ref_lab = filtered_colour(ref, w, h);
  const std::vector<Vec3> tst_lab = filtered_colour(tst, w, h);

  // Features: Delta E_f = ((1 / sqrt 2) max(|edge_r - edge_t|, |point_r - point_t|))^qf.
  const FeatureKernels k = feature_kernels();
  const Features ref_f = features(ref.luminance, w, h, k);
  const Features tst_f = features(tst.luminance, w, h, k);

  std::vector<double> out(src.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double colour = redistribute(std::pow(hyab(ref_lab[i], tst_lab[i]), kQc), cmax);
    const double feature =
        std::pow(std::max(std::abs(ref_f.edge[i] - tst_f.edge[i]),
                          std::abs(ref_f.point[i] - tst_f.point[i])) /
                     std::numbers::sqrt2,
                 kQf);
    // Final error: Delta E = Delta E_c ^ (1 - Delta E_f).
    out[i] = std::pow(colour, 1.0 - feature);
  }
  return out;
}

}  // namespace

Expected<double> flip(const ImageView& reference, const ImageView& test, const Mask& mask) {
  auto counted = detail::check_inputs("flip", reference, test, mask);
  if (!counted) return counted.error();
  const std::vector<double> map = flip_pixels(reference, test, mask);
  double total = 0.0;
  for (std::size_t i = 0; i < map.size(); ++i)
    if (detail::counts(mask, i)) total += map[i];
  return total / static_cast<double>(*counted);
}

Expected<std::vector<float>> flip_map(const ImageView& reference, const ImageView& test) {
  return flip_map(reference, test, Mask{});
}

Expected<std::vector<float>> flip_map(const ImageView& reference, const ImageView& test,
                                      const Mask& mask) {
  auto counted = detail::check_inputs("flip_map", reference, test, mask);
  if (!counted) return counted.error();
  const std::vector<double> map = flip_pixels(reference, test, mask);
  std::vector<float> out(map.size(), 0.0f);
  for (std::size_t i = 0; i < map.size(); ++i)
    if (detail::counts(mask, i)) out[i] = static_cast<float>(map[i]);
  return out;
}

}  // namespace gauss::eval
