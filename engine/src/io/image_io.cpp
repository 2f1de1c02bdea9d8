#include "gauss/engine/image_io.h"

#include <array>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <string>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
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

Error image_error(const std::filesystem::path& path, const std::string& what) {
  return Error{path.string() + ": " + what};
}

enum class ImageKind { Unreadable, Png, Jpeg, Other };

// What the file is, by its first bytes (stb would decode any format it was built with).
ImageKind sniff(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return ImageKind::Unreadable;
  std::array<unsigned char, 8> b{};
  in.read(reinterpret_cast<char*>(b.data()), std::streamsize(b.size()));
  const auto n = std::size_t(in.gcount());
  static constexpr std::array<unsigned char, 8> kPng{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n == 8 && b == kPng) return ImageKind::Png;
  if (n >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff) return ImageKind::Jpeg;
  return ImageKind::Other;
}

// Why a file that should be a PNG is not one, or an empty string when it is.
std::string not_png_reason(const std::filesystem::path& path) {
  switch (sniff(path)) {
    case ImageKind::Png: return {};
    case ImageKind::Unreadable: return "cannot read PNG: cannot open file";
    case ImageKind::Jpeg: return "cannot read PNG: the file is a JPEG";
    case ImageKind::Other: break;
  }
  return "cannot read PNG: not a PNG file (no PNG signature)";
}

Expected<ImageRGBA8> decode_rgba8(const std::filesystem::path& path, const char* what) {
  int w = 0, h = 0, channels = 0;
  std::unique_ptr<stbi_uc, StbiFree> data(stbi_load(path.c_str(), &w, &h, &channels, 4));
  if (!data) return image_error(path, std::string("cannot read ") + what + ": " + stbi_failure_reason());
  ImageRGBA8 img;
  img.width = std::uint32_t(w);
  img.height = std::uint32_t(h);
  img.pixels.assign(data.get(), data.get() + std::size_t(w) * std::size_t(h) * 4);
  return img;
}

// Checks an RGBA8 image before writing it; an empty string when it is consistent.
std::string bad_rgba8(const ImageRGBA8& image) {
  if (image.width == 0 || image.height == 0) return "cannot write an empty image";
  if (image.width > std::uint32_t(std::numeric_limits<int>::max() / 4) ||
      image.pixels.size() != std::size_t(image.width) * image.height * 4)
    return "pixel buffer size " + std::to_string(image.pixels.size()) + " does not match " +
           std::to_string(image.width) + "x" + std::to_string(image.height) + " RGBA8";
  return {};
}

}  // namespace

Status write_png(const std::filesystem::path& path, const ImageRGBA8& image) {
  if (auto why = bad_rgba8(image); !why.empty()) return image_error(path, why);
  const int ok = stbi_write_png(path.c_str(), int(image.width), int(image.height), 4,
                                image.pixels.data(), int(image.width * 4));
  if (!ok) return image_error(path, "could not write PNG");
  return Ok{};
}

Status write_jpeg(const std::filesystem::path& path, const ImageRGBA8& image, int quality) {
  if (auto why = bad_rgba8(image); !why.empty()) return image_error(path, why);
  if (quality < 1 || quality > 100)
    return image_error(path, "JPEG quality " + std::to_string(quality) + " is not in 1..100");
  const int ok = stbi_write_jpg(path.c_str(), int(image.width), int(image.height), 4, image.pixels.data(), quality);
  if (!ok) return image_error(path, "could not write JPEG");
  return Ok{};
}

Expected<ImageRGBA8> read_png_rgba8(const std::filesystem::path& path) {
  if (auto why = not_png_reason(path); !why.empty()) return image_error(path, why);
  return decode_rgba8(path, "PNG");
}

Expected<ImageRGBA8> read_image_rgba8(const std::filesystem::path& path) {
  switch (sniff(path)) {
    case ImageKind::Png: return decode_rgba8(path, "PNG");
    case ImageKind::Jpeg: return decode_rgba8(path, "JPEG");
    case ImageKind::Unreadable: return image_error(path, "cannot read image: cannot open file");
    case ImageKind::Other: break;
  }
  return image_error(path, "cannot read image: neither a PNG nor a JPEG (by its first bytes)");
}

Expected<ImageU16> read_png_u16(const std::filesystem::path& path) {
  if (auto why = not_png_reason(path); !why.empty()) return image_error(path, why);
  int w = 0, h = 0, channels = 0;
  if (!stbi_info(path.c_str(), &w, &h, &channels))
    return image_error(path, std::string("cannot read PNG: ") + stbi_failure_reason());
  if (!stbi_is_16_bit(path.c_str()))
    return image_error(path, "expected a 16-bit PNG, found 8-bit samples");
  if (channels != 1)
    return image_error(path, "expected a single-channel 16-bit PNG, found " + std::to_string(channels) + " channels");
  std::unique_ptr<stbi_us, StbiFree> data(stbi_load_16(path.c_str(), &w, &h, &channels, 1));
  if (!data) return image_error(path, std::string("cannot decode PNG: ") + stbi_failure_reason());
  ImageU16 img;
  img.width = std::uint32_t(w);
  img.height = std::uint32_t(h);
  img.pixels.assign(data.get(), data.get() + std::size_t(w) * std::size_t(h));
  return img;
}

}  // namespace gauss
