#pragma once
// PNG read/write (stb). Images are row-major, top row first.
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
// Reads any 8-bit PNG as RGBA8 (grey/RGB expanded, alpha 255 when absent).
Expected<ImageRGBA8> read_png_rgba8(const std::filesystem::path& path);
// Reads a single-channel 16-bit PNG (depth images). An 8-bit or multi-channel PNG is an error.
Expected<ImageU16> read_png_u16(const std::filesystem::path& path);

}  // namespace gauss
