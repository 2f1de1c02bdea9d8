#pragma once
// WebP images as raw 8-bit RGBA, for readers whose images carry data, not pictures (SOG).
// Private to engine/.
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss::io {

struct WebpInfo {
  int width{0};
  int height{0};
  bool lossless{false};
  bool animated{false};
};

// Reads the bitstream header only (no pixel decoding): dimensions and kind, so callers can
// check the size before allocating. Errors name `what` and say what the bytes are not.
Expected<WebpInfo> webp_info(std::span<const std::uint8_t> bytes, std::string_view what);

struct RgbaImage {
  int width{0};
  int height{0};
  std::vector<std::uint8_t> rgba;  // width * height * 4 bytes, row-major from the top-left
};

// Decodes a still WebP to RGBA8 (alpha 255 where the image has none). Lossy images are
// rejected unless `allow_lossy`: their values are no longer the integers that were stored.
// Errors name `what`.
Expected<RgbaImage> decode_webp_rgba(std::span<const std::uint8_t> bytes, std::string_view what,
                                     bool allow_lossy = false);

}  // namespace gauss::io
