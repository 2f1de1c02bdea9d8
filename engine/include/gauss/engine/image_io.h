#pragma once
// PNG and JPEG read/write (stb; 16-bit PNG written with zlib). Images are row-major, top row first.
#include <cstdint>
#include <filesystem>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss {

struct ImageRGBA8 {
  std::uint32_t width{0};
  std::uint32_t height{0};
  std::vector<std::uint8_t> pixels;  // width * height * 4 bytes, R G B A
};

struct ImageU16 {
  std::uint32_t width{0};
  std::uint32_t height{0};
  std::vector<std::uint16_t> pixels;  // width * height samples (e.g. depth in millimetres)
};

// Writes an RGBA8 PNG. Fails (naming the file) on an inconsistent image or an unwritable path.
Status write_png(const std::filesystem::path& path, const ImageRGBA8& image);
// Writes a single-channel 16-bit PNG (depth images; stb writes 8-bit only, so this one is
// zlib + the PNG chunks). Fails (naming the file) like write_png.
Status write_png_u16(const std::filesystem::path& path, const ImageU16& image);
// Writes a baseline JPEG, quality 1..100 (colour frames of RGB-D test captures; alpha dropped).
Status write_jpeg(const std::filesystem::path& path, const ImageRGBA8& image, int quality = 95);
// Reads any 8-bit PNG as RGBA8 (grey/RGB expanded, alpha 255 when absent). A file that is not
// a PNG (by its signature) is an error, whatever its extension.
Expected<ImageRGBA8> read_png_rgba8(const std::filesystem::path& path);
// Reads a PNG or a JPEG (baseline or progressive), recognised by content, as RGBA8.
Expected<ImageRGBA8> read_image_rgba8(const std::filesystem::path& path);
// Reads a single-channel 16-bit PNG (depth images). A JPEG, an 8-bit or a multi-channel PNG is an
// error that says which it found.
Expected<ImageU16> read_png_u16(const std::filesystem::path& path);

}  // namespace gauss
