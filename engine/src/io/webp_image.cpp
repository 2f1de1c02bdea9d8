// WebP decoding through libwebp (webp_image.h).
#include "io/webp_image.h"

#include <string>

#include <webp/decode.h>

namespace gauss::io {
namespace {

std::string status_text(VP8StatusCode s) {
  switch (s) {
    case VP8_STATUS_OK: return "ok";
    case VP8_STATUS_OUT_OF_MEMORY: return "out of memory";
    case VP8_STATUS_INVALID_PARAM: return "invalid parameter";
    case VP8_STATUS_BITSTREAM_ERROR: return "bitstream error";
    case VP8_STATUS_UNSUPPORTED_FEATURE: return "unsupported feature";
    case VP8_STATUS_SUSPENDED: return "suspended";
    case VP8_STATUS_USER_ABORT: return "user abort";
    case VP8_STATUS_NOT_ENOUGH_DATA: return "not enough data (truncated image)";
  }
  return "unknown status " + std::to_string(static_cast<int>(s));
}

}  // namespace

Expected<WebpInfo> webp_info(std::span<const std::uint8_t> bytes, std::string_view what) {
  WebPBitstreamFeatures f{};
  const VP8StatusCode s = WebPGetFeatures(bytes.data(), bytes.size(), &f);
  if (s != VP8_STATUS_OK)
    return Error{std::string(what) + ": not a readable WebP image (" + status_text(s) + ", " +
                 std::to_string(bytes.size()) + " bytes)"};
  if (f.width <= 0 || f.height <= 0)
    return Error{std::string(what) + ": WebP image reports size " + std::to_string(f.width) + "x" +
                 std::to_string(f.height)};
  WebpInfo info;
  info.width = f.width;
  info.height = f.height;
  info.lossless = f.format == 2;
  info.animated = f.has_animation != 0;
  return info;
}

Expected<RgbaImage> decode_webp_rgba(std::span<const std::uint8_t> bytes, std::string_view what, bool allow_lossy) {
  auto info = webp_info(bytes, what);
  if (!info) return info.error();
  if (info->animated) return Error{std::string(what) + ": an animated WebP; expected a still image"};
  if (!info->lossless && !allow_lossy)
    return Error{std::string(what) +
                 ": a lossy WebP; its pixels are stored integers (indices, bit fields) that lossy "
                 "compression has altered, so it must be lossless"};
  RgbaImage image;
  image.width = info->width;
  image.height = info->height;
  const std::size_t stride = std::size_t(image.width) * 4;
  image.rgba.resize(stride * std::size_t(image.height));
  if (!WebPDecodeRGBAInto(bytes.data(), bytes.size(), image.rgba.data(), image.rgba.size(), static_cast<int>(stride)))
    return Error{std::string(what) + ": WebP decoding failed (" + std::to_string(image.width) + "x" +
                 std::to_string(image.height) + " image, " + std::to_string(bytes.size()) +
                 " bytes: damaged or truncated data)"};
  return image;
}

}  // namespace gauss::io
