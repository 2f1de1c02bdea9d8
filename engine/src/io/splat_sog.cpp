// PlayCanvas SOG reader (splat_file.h): meta.json plus lossless WebP images, zipped (.sog) or
// as a folder. Specification: developer.playcanvas.com "The SOG Format" (version 2); the
// unversioned legacy layout (version 1) is read as the PlayCanvas engine reads it.
//
// Every per-Gaussian image is W x H with count <= W*H (the same W x H for all of them); Gaussian
// i is pixel (i % W, i / W), channels R G B A. Images are named by meta.json, so any names work.
//
// Quantisation (version 2, as splat-transform writes it; "trunc" because its JS integer
// conversions truncate):
//   position  16 bits per axis, split over means_l (low byte) and means_u (high byte), in the log
//             domain n = sign(x) ln(1 + |x|): q = trunc(65535 (n - min) / (max - min)), decoded
//             n = min + (max - min) q / 65535, x = sign(n) (exp(|n|) - 1). n is low by less than
//             (max - min) / 65535, so |error in x| < (max - min) / 65535 * (1 + |x|).
//   rotation  quats: A = 252 + index of the largest component (0 = w), which is rebuilt as
//             sqrt(1 - a^2 - b^2 - c^2) >= 0; R G B = the other three in w x y z order, each
//             c = (byte / 255 - 0.5) sqrt(2). The writer truncates: each stored component is off
//             by < sqrt(2) / 255 = 0.0055, the rebuilt one by < 3x that to first order.
//   log-scale scales: R G B index meta.json scales.codebook (256 values, one 1-D k-means over all
//             three axes): the error is the distance to the assigned centroid, data-dependent
//             (measured in tests/engine/test_splat_compressed_sog.cpp).
//   colour    sh0 R G B index sh0.codebook, which holds f_dc values (the same kind of codebook).
//   opacity   sh0 A = trunc(255 sigmoid(opacity)): alpha = A / 255 is low by < 1/255;
//             opacity_logit = logit(clamp(alpha, 0.5/255, 1 - 0.5/255)) (A = 0 has no finite
//             logit; see splat_quantized.h: compare opacities, not logits). Where A = 0, a
//             lossless WebP encoder without its "exact" setting may replace R G B: splat-transform
//             2.7.1 does (all 40 such Gaussians of fruit_drops_sh3.sog read colour indices 0 0 0,
//             which no other Gaussian there has). Those Gaussians are invisible (alpha < 1/255);
//             the reader cannot restore their colour.
//   sh rest   shN_labels R + 256 G = palette entry (< shN.count); entry e's coefficient k is
//             pixel ((e % 64) * coeffs + k, e / 64) of shN_centroids (coeffs = 3, 8, 15 for
//             bands 1..3, so its width is 64 * coeffs), R G B = channels, each an index into
//             shN.codebook. A k-means palette: per-Gaussian error is unbounded by the format
//             (measured in the test).
// Version 1 (no "version" field; count = means.shape[0]) differs in scales, sh0 and shN: bytes
// are linear between per-channel meta mins/maxs (byte / 255); sh0's fourth channel is the
// opacity logit itself, not a sigmoid; the SH bands follow from the centroid width (192, 512,
// 960) and the palette size from its height.
//
// Checks (each failure names the input, and the zip entry or file and the pixel): meta.json as
// in splat_sog_meta.h; every image a still, lossless WebP (a lossy one has lost its integers);
// per-Gaussian images all W x H with count <= W*H <= 4 count + 65536 (more padding than any
// writer uses is refused, so a tiny constant image cannot make the reader decode 16383^2
// pixels); a quaternion tag outside 252..255; a codebook index past the codebook or at a null
// entry; a palette label >= shN.count (or outside the centroid image). Never a partial cloud.
// Ids are the index; no object labels. meta.json's "antialias" flag has no place in a
// GaussianCloud and is ignored.
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "gauss/engine/splat_file.h"
#include "io/file_bytes.h"
#include "io/memory_room.h"
#include "io/splat_quantized.h"
#include "io/splat_sog_meta.h"
#include "io/webp_image.h"
#include "io/zip_archive.h"

namespace gauss {
namespace {

using io::RgbaImage;
using io::SogCodebook;
using io::SogMeta;

constexpr std::size_t kMaxMetaBytes = std::size_t(64) << 20;
constexpr std::size_t kMaxImageBytes = std::size_t(256) << 20;
constexpr int kPaletteRow = 64;            // palette entries per centroid image row
constexpr int kMaxCentroidRows = 65536 / kPaletteRow;  // labels are 16-bit

// Where a SOG's files come from: a zip archive or a folder.
class SogFiles {
 public:
  virtual ~SogFiles() = default;
  virtual Expected<std::vector<std::uint8_t>> read(const std::string& file, std::size_t max_bytes) const = 0;
  // How messages name `file` ("scene.sog: entry 'quats.webp'", "scene/quats.webp").
  virtual std::string describe(const std::string& file) const = 0;
};

class ZipFiles final : public SogFiles {
 public:
  explicit ZipFiles(io::ZipArchive zip, std::string name) : zip_(std::move(zip)), name_(std::move(name)) {}
  Expected<std::vector<std::uint8_t>> read(const std::string& file, std::size_t max_bytes) const override {
    return zip_.read(file, max_bytes);
  }
  std::string describe(const std::string& file) const override { return name_ + ": entry '" + file + "'"; }

 private:
  io::ZipArchive zip_;
  std::string name_;
};

class FolderFiles final : public SogFiles {
 public:
  explicit FolderFiles(std::filesystem::path folder) : folder_(std::move(folder)) {}
  Expected<std::vector<std::uint8_t>> read(const std::string& file, std::size_t max_bytes) const override {
    const std::filesystem::path p = folder_ / file;
    std::error_code ec;
    const auto size = std::filesystem::file_size(p, ec);
    if (!ec && size > max_bytes)
      return Error{p.string() + ": " + std::to_string(size) + " bytes, more than the " + std::to_string(max_bytes) +
                   " this reader accepts"};
    return io::read_file_bytes(p);  // names the path when missing or unreadable
  }
  std::string describe(const std::string& file) const override { return (folder_ / file).string(); }

 private:
  std::filesystem::path folder_;
};

std::string pixel_of(std::size_t i, int width) {
  return "Gaussian " + std::to_string(i) + ", pixel (" + std::to_string(i % std::size_t(width)) + ", " +
         std::to_string(i / std::size_t(width)) + ")";
}

// The per-Gaussian image size every image must share, fixed by the first one loaded.
struct Grid {
  int width{0};
  int height{0};
};

// Loads one per-Gaussian image, checking its size against meta.json's count and `grid`.
Expected<RgbaImage> load_grid_image(const SogFiles& files, const std::string& file, const char* role,
                                    std::size_t count, Grid& grid) {
  const std::string who = files.describe(file) + " (" + role + ")";
  auto bytes = files.read(file, kMaxImageBytes);
  if (!bytes) return bytes.error();
  auto info = io::webp_info(*bytes, who);
  if (!info) return info.error();
  const std::size_t pixels = std::size_t(info->width) * std::size_t(info->height);
  const std::string size = std::to_string(info->width) + "x" + std::to_string(info->height);
  if (grid.width == 0) {
    if (pixels < count)
      return Error{who + ": " + size + " = " + std::to_string(pixels) + " pixels, fewer than meta.json's count of " +
                   std::to_string(count) + " Gaussians"};
    if (pixels > 4 * count + 65536)
      return Error{who + ": " + size + " = " + std::to_string(pixels) + " pixels for " + std::to_string(count) +
                   " Gaussians (more than 4 count + 65536: not a SOG layout)"};
    grid = Grid{info->width, info->height};
  } else if (info->width != grid.width || info->height != grid.height) {
    return Error{who + ": " + size + ", but the other per-Gaussian images are " + std::to_string(grid.width) + "x" +
                 std::to_string(grid.height) + " (pixel i of every image is Gaussian i)"};
  }
  return io::decode_webp_rgba(*bytes, who);
}

// Why codebook entry `index` cannot be used, or empty when it can.
std::string unusable(const SogCodebook& cb, std::uint8_t index) {
  if (index >= cb.values.size()) return "has only " + std::to_string(cb.values.size()) + " entries";
  if (!cb.valid[index]) return "is null there (an empty cluster)";
  return {};
}

std::string bad_entry(std::uint8_t index, const char* field, const std::string& why) {
  return " uses entry " + std::to_string(index) + " of meta.json '" + field + "', which " + why;
}

double lerp_byte(double lo, double hi, std::uint8_t b) { return lo + (hi - lo) * (double(b) / 255.0); }

void decode_positions(const SogMeta& m, const RgbaImage& lo, const RgbaImage& hi, std::vector<Gaussian>& gs) {
  for (std::size_t i = 0; i < gs.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      const std::size_t o = 4 * i + std::size_t(a);
      const unsigned q = unsigned(hi.rgba[o]) << 8 | unsigned(lo.rgba[o]);
      const std::size_t k = std::size_t(a);
      const double n = m.means_min[k] + (m.means_max[k] - m.means_min[k]) * (double(q) / 65535.0);
      gs[i].position[a] = static_cast<float>(std::copysign(std::expm1(std::abs(n)), n));
    }
}

Status decode_rotations(const RgbaImage& img, const std::string& who, std::vector<Gaussian>& gs) {
  const double sqrt2 = std::sqrt(2.0);
  for (std::size_t i = 0; i < gs.size(); ++i) {
    const std::uint8_t* p = &img.rgba[4 * i];
    if (p[3] < 252)
      return Error{who + ": " + pixel_of(i, img.width) + " has quaternion tag (alpha) " + std::to_string(p[3]) +
                   "; expected 252..255 (252 + index of the largest component)"};
    auto comp = [&](int k) { return (double(p[k]) / 255.0 - 0.5) * sqrt2; };
    gs[i].rotation = io::rebuild_quaternion(p[3] - 252, comp(0), comp(1), comp(2));
  }
  return Ok{};
}

Status decode_scales(const SogMeta& m, const RgbaImage& img, const std::string& who, std::vector<Gaussian>& gs) {
  for (std::size_t i = 0; i < gs.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      const std::uint8_t b = img.rgba[4 * i + std::size_t(a)];
      if (m.version == 2) {
        if (const std::string why = unusable(m.scales_codebook, b); !why.empty())
          return Error{who + ": " + pixel_of(i, img.width) + bad_entry(b, "scales.codebook", why)};
        gs[i].log_scale[a] = m.scales_codebook.values[b];
      } else {
        const std::size_t k = std::size_t(a);
        gs[i].log_scale[a] = static_cast<float>(lerp_byte(m.scales_min[k], m.scales_max[k], b));
      }
    }
  return Ok{};
}

Status decode_colours(const SogMeta& m, const RgbaImage& img, const std::string& who, std::vector<Gaussian>& gs) {
  for (std::size_t i = 0; i < gs.size(); ++i) {
    const std::uint8_t* p = &img.rgba[4 * i];
    for (int a = 0; a < 3; ++a) {
      if (m.version == 2) {
        if (const std::string why = unusable(m.sh0_codebook, p[a]); !why.empty())
          return Error{who + ": " + pixel_of(i, img.width) + bad_entry(p[a], "sh0.codebook", why)};
        gs[i].sh_dc[a] = m.sh0_codebook.values[p[a]];
      } else {
        const std::size_t k = std::size_t(a);
        gs[i].sh_dc[a] = static_cast<float>(lerp_byte(m.sh0_min[k], m.sh0_max[k], p[a]));
      }
    }
    gs[i].opacity_logit = m.version == 2 ? io::alpha_to_logit(double(p[3]) / 255.0)
                                         : static_cast<float>(lerp_byte(m.sh0_min[3], m.sh0_max[3], p[3]));
  }
  return Ok{};
}

// Higher SH bands through the palette; returns the SH degree.
Expected<int> decode_sh_rest(const SogMeta& m, const SogFiles& files, std::size_t count, Grid& grid,
                             std::vector<Gaussian>& gs) {
  const std::string cwho = files.describe(m.shn_centroids) + " (shN centroids)";
  auto cbytes = files.read(m.shn_centroids, kMaxImageBytes);
  if (!cbytes) return cbytes.error();
  auto info = io::webp_info(*cbytes, cwho);
  if (!info) return info.error();
  int bands = m.shn_bands;
  if (m.version == 1) {
    for (int d = 1; d <= kMaxShDegree; ++d)
      if (info->width == kPaletteRow * sh_rest_count(d)) bands = d;
    if (bands == 0)
      return Error{cwho + ": width " + std::to_string(info->width) +
                   " is not 192, 512 or 960 (64 palette entries of 3, 8 or 15 coefficients per row)"};
  }
  const int coefs = sh_rest_count(bands);
  if (info->width != kPaletteRow * coefs)
    return Error{cwho + ": width " + std::to_string(info->width) + "; meta.json shN.bands = " + std::to_string(bands) +
                 " needs 64 x " + std::to_string(coefs) + " = " + std::to_string(kPaletteRow * coefs)};
  if (info->height > kMaxCentroidRows)
    return Error{cwho + ": height " + std::to_string(info->height) + " holds more than the 65536 entries 16-bit labels can address"};
  const std::size_t addressable = std::size_t(info->height) * kPaletteRow;
  std::size_t palette = addressable;
  if (m.version == 2) {
    if (addressable < m.shn_count)
      return Error{cwho + ": " + std::to_string(info->height) + " rows hold " + std::to_string(addressable) +
                   " palette entries, fewer than meta.json shN.count = " + std::to_string(m.shn_count)};
    palette = m.shn_count;
  }
  auto centroids = io::decode_webp_rgba(*cbytes, cwho);
  if (!centroids) return centroids.error();
  const std::string lwho = files.describe(m.shn_labels) + " (shN labels)";
  auto labels = load_grid_image(files, m.shn_labels, "shN labels", count, grid);
  if (!labels) return labels.error();

  const std::size_t row = std::size_t(centroids->width) * 4;
  for (std::size_t i = 0; i < gs.size(); ++i) {
    const std::size_t label = std::size_t(labels->rgba[4 * i]) | std::size_t(labels->rgba[4 * i + 1]) << 8;
    if (label >= palette)
      return Error{lwho + ": " + pixel_of(i, labels->width) + " has palette label " + std::to_string(label) +
                   ", but the palette has " + std::to_string(palette) + " entries"};
    const std::uint8_t* entry = centroids->rgba.data() + (label / kPaletteRow) * row +
                                (label % kPaletteRow) * std::size_t(coefs) * 4;
    for (int k = 0; k < coefs; ++k)
      for (int c = 0; c < 3; ++c) {
        const std::uint8_t b = entry[4 * k + c];
        float v = 0.0f;
        if (m.version == 2) {
          if (const std::string why = unusable(m.shn_codebook, b); !why.empty())
            return Error{cwho + ": palette entry " + std::to_string(label) + ", coefficient " + std::to_string(k) +
                         bad_entry(b, "shN.codebook", why)};
          v = m.shn_codebook.values[b];
        } else {
          v = static_cast<float>(lerp_byte(m.shn_min, m.shn_max, b));
        }
        gs[i].sh_rest[static_cast<std::size_t>(k)][c] = v;
      }
  }
  return bands;
}

Expected<SplatScene> decode_sog(const SogFiles& files, std::span<const std::uint8_t> meta_bytes,
                                const std::string& meta_what) {
  auto meta = io::parse_sog_meta(meta_bytes, meta_what);
  if (!meta) return meta.error();
  const SogMeta& m = *meta;

  SplatScene scene;
  scene.report.format = SplatFormat::Sog;
  scene.report.version = static_cast<std::uint32_t>(m.version);
  std::vector<Gaussian>& gs = scene.cloud.gaussians;
  if (auto s = io::resize_cloud(gs, m.count, meta_what); !s) return s.error();
  Grid grid;

  auto means_l = load_grid_image(files, m.means_l, "means, low bytes", m.count, grid);
  if (!means_l) return means_l.error();
  auto means_u = load_grid_image(files, m.means_u, "means, high bytes", m.count, grid);
  if (!means_u) return means_u.error();
  decode_positions(m, *means_l, *means_u, gs);

  auto quats = load_grid_image(files, m.quats, "quaternions", m.count, grid);
  if (!quats) return quats.error();
  if (Status st = decode_rotations(*quats, files.describe(m.quats), gs); !st) return st.error();

  auto scales = load_grid_image(files, m.scales, "scales", m.count, grid);
  if (!scales) return scales.error();
  if (Status st = decode_scales(m, *scales, files.describe(m.scales), gs); !st) return st.error();

  auto sh0 = load_grid_image(files, m.sh0, "colour and opacity", m.count, grid);
  if (!sh0) return sh0.error();
  if (Status st = decode_colours(m, *sh0, files.describe(m.sh0), gs); !st) return st.error();

  if (m.has_shn) {
    auto degree = decode_sh_rest(m, files, m.count, grid, gs);
    if (!degree) return degree.error();
    scene.cloud.sh_degree = *degree;
  }
  io::finish_quantized_scene(scene);
  return scene;
}

}  // namespace

Expected<SplatScene> parse_sog_zip(std::span<const std::uint8_t> bytes, std::string_view name) {
  auto zip = io::ZipArchive::open(bytes, name);
  if (!zip) return zip.error();
  if (!zip->contains("meta.json")) {
    std::string listing;
    const auto entries = zip->entry_names();
    for (std::size_t k = 0; k < entries.size() && k < 8; ++k) listing += (k ? ", " : "") + entries[k];
    if (entries.size() > 8) listing += ", ... (" + std::to_string(entries.size()) + " entries)";
    return Error{std::string(name) + ": a zip without meta.json at its root, so not a SOG (entries: " +
                 (listing.empty() ? std::string("none") : listing) + ")"};
  }
  auto meta = zip->read("meta.json", kMaxMetaBytes);
  if (!meta) return meta.error();
  const ZipFiles files(std::move(*zip), std::string(name));
  return decode_sog(files, *meta, files.describe("meta.json"));
}

Expected<SplatScene> read_sog_folder(const std::filesystem::path& folder) {
  const std::filesystem::path dir = folder.empty() ? std::filesystem::path(".") : folder;
  const FolderFiles files(dir);
  auto meta = files.read("meta.json", kMaxMetaBytes);
  if (!meta) return meta.error();
  return decode_sog(files, *meta, files.describe("meta.json"));
}

}  // namespace gauss
