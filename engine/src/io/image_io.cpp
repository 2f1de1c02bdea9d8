#include "gauss/engine/image_io.h"

#include <cstring>
#include <limits>
#include <memory>
#include <string>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBI_ONLY_PNG
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wsign-compare"
#endif
#include <stb_image.h>
#include <stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace gauss {
namespace {

struct StbiFree {
  void operator()(void* p) const { stbi_image_free(p); }
};

Error png_error(const std::filesystem::path& path, const std::string& what) {
  return Error{path.string() + ": " + what};
}

}  // namespace

Status write_png(const std::filesystem::path& path, const ImageRGBA8& image) {
  if (image.width == 0 || image.height == 0)
    return png_error(path, "cannot write an empty image");
  if (image.width > std::uint32_t(std::numeric_limits<int>::max() / 4) ||
      image.pixels.size() != std::size_t(image.width) * image.height * 4)
    return png_error(path, "pixel buffer size " + std::to_string(image.pixels.size()) +
                               " does not match " + std::to_string(image.width) + "x" +
                               std::to_string(image.height) + " RGBA8");
  const int ok = stbi_write_png(path.c_str(), int(image.width), int(image.height), 4,
                                image.pixels.data(), int(image.width * 4));
  if (!ok) return png_error(path, "could not write PNG");
  return Ok{};
}

Expected<ImageRGBA8> read_png_rgba8(const std::filesystem::path& path) {
  int w = 0, h = 0, channels = 0;
  std::unique_ptr<stbi_uc, StbiFree> data(stbi_load(path.c_str(), &w, &h, &channels, 4));
  if (!data) return png_error(path, std::string("cannot read PNG: ") + stbi_failure_reason());
  ImageRGBA8 img;
  img.width = std::uint32_t(w);
  img.height = std::uint32_t(h);
  img.pixels.assign(data.get(), data.get() + std::size_t(w) * std::size_t(h) * 4);
  return img;
}

Expected<ImageU16> read_png_u16(const std::filesystem::path& path) {
  int w = 0, h = 0, channels = 0;
  if (!stbi_info(path.c_str(), &w, &h, &channels))
    return png_error(path, std::string("cannot read PNG: ") + stbi_failure_reason());
  if (!stbi_is_16_bit(path.c_str()))
    return png_error(path, "expected a 16-bit PNG, found 8-bit samples");
  if (channels != 1)
    return png_error(path, "expected a single-channel 16-bit PNG, found " + std::to_string(channels) + " channels");
  std::unique_ptr<stbi_us, StbiFree> data(stbi_load_16(path.c_str(), &w, &h, &channels, 1));
  if (!data) return png_error(path, std::string("cannot decode PNG: ") + stbi_failure_reason());
  ImageU16 img;
  img.width = std::uint32_t(w);
  img.height = std::uint32_t(h);
  img.pixels.assign(data.get(), data.get() + std::size_t(w) * std::size_t(h));
  return img;
}

}  // namespace gauss
