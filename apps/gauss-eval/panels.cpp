#include "panels.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace gauss::eval_app {

namespace {

// Magma sampled at nine evenly spaced points (8-bit, close to matplotlib's table).
constexpr std::array<std::array<std::uint8_t, 3>, 9> kMagma{{{0, 0, 4},
                                                              {28, 16, 68},
                                                              {79, 18, 123},
                                                              {129, 37, 129},
                                                              {181, 54, 122},
                                                              {229, 80, 100},
                                                              {251, 135, 97},
                                                              {254, 194, 135},
                                                              {252, 253, 191}}};

}  // namespace

ImageRGBA8 flip_image(const std::vector<float>& map, std::uint32_t width, std::uint32_t height) {
  ImageRGBA8 out;
  out.width = width;
  out.height = height;
  out.pixels.assign(std::size_t(width) * height * 4, 255);
  for (std::size_t i = 0; i < std::min(map.size(), std::size_t(width) * height); ++i) {
    const float v = std::clamp(std::isfinite(map[i]) ? map[i] : 1.0f, 0.0f, 1.0f) * float(kMagma.size() - 1);
    const auto k = std::min<std::size_t>(static_cast<std::size_t>(v), kMagma.size() - 2);
    const float f = v - float(k);
    for (int c = 0; c < 3; ++c)
      out.pixels[i * 4 + c] =
          static_cast<std::uint8_t>(std::lround((1.0f - f) * kMagma[k][c] + f * kMagma[k + 1][c]));
  }
  return out;
}

Status PanelWriter::write(const std::string& name, const std::vector<const ImageRGBA8*>& images) const {
  if (!enabled_ || images.empty()) return Ok{};
  constexpr std::uint32_t kGap = 4;
  const std::uint32_t w = images.front()->width, h = images.front()->height;
  for (const ImageRGBA8* im : images)
    if (im->width != w || im->height != h) return Error{"panels " + name + ": images of different sizes"};
  ImageRGBA8 sheet;
  sheet.width = static_cast<std::uint32_t>(images.size()) * (w + kGap) - kGap;
  sheet.height = h;
  sheet.pixels.assign(std::size_t(sheet.width) * h * 4, 255);
  for (std::size_t k = 0; k < images.size(); ++k)
    for (std::uint32_t y = 0; y < h; ++y) {
      const std::uint8_t* src = &images[k]->pixels[std::size_t(y) * w * 4];
      std::uint8_t* dst = &sheet.pixels[(std::size_t(y) * sheet.width + k * (w + kGap)) * 4];
      std::copy(src, src + std::size_t(w) * 4, dst);
    }
  return write_png(dir_ / (name + ".png"), sheet);
}

}  // namespace gauss::eval_app
