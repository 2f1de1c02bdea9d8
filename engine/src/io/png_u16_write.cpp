// 16-bit greyscale PNG writing (depth images). stb_image_write only writes 8-bit samples,
// so this one assembles the PNG itself: signature, IHDR (bit depth 16, colour type 0),
// one zlib-compressed IDAT of the rows (filter byte 0, samples big-endian), IEND.
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <zlib.h>

#include "file_bytes.h"
#include "gauss/engine/image_io.h"

namespace gauss {
namespace {

void put_u32_be(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(std::uint8_t(v >> s));
}

// Appends one chunk: length, type, data, CRC-32 over type and data.
void put_chunk(std::vector<std::uint8_t>& out, const char (&type)[5], const std::vector<std::uint8_t>& data) {
  put_u32_be(out, std::uint32_t(data.size()));
  const std::size_t type_at = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  const uLong crc = crc32(0L, out.data() + type_at, uInt(out.size() - type_at));
  put_u32_be(out, std::uint32_t(crc));
}

}  // namespace

Status write_png_u16(const std::filesystem::path& path, const ImageU16& image) {
  const auto fail = [&](const std::string& what) { return Error{path.string() + ": " + what}; };
  if (image.width == 0 || image.height == 0) return fail("cannot write an empty image");
  // Each row is 1 filter byte + 2 bytes per sample; the whole raw stream must fit zlib's uLong.
  if (image.width > 1u << 24 || image.height > 1u << 24 ||
      image.pixels.size() != std::size_t(image.width) * image.height)
    return fail("sample count " + std::to_string(image.pixels.size()) + " does not match " +
                std::to_string(image.width) + "x" + std::to_string(image.height) + " 16-bit grey");
  const std::size_t row_bytes = 1 + std::size_t(image.width) * 2;
  std::vector<std::uint8_t> raw(row_bytes * image.height);
  for (std::size_t y = 0; y < image.height; ++y) {
    std::uint8_t* row = &raw[y * row_bytes];
    row[0] = 0;  // filter: none
    for (std::size_t x = 0; x < image.width; ++x) {
      const std::uint16_t v = image.pixels[y * image.width + x];
      row[1 + 2 * x] = std::uint8_t(v >> 8);
      row[2 + 2 * x] = std::uint8_t(v & 0xff);
    }
  }
  if (raw.size() > std::numeric_limits<uLong>::max() / 2) return fail("image too large to compress");
  uLongf packed_size = compressBound(uLong(raw.size()));
  std::vector<std::uint8_t> packed(packed_size);
  if (compress2(packed.data(), &packed_size, raw.data(), uLong(raw.size()), 6) != Z_OK)
    return fail("zlib could not compress the samples");
  packed.resize(packed_size);

  std::vector<std::uint8_t> ihdr;
  put_u32_be(ihdr, image.width);
  put_u32_be(ihdr, image.height);
  ihdr.insert(ihdr.end(), {16, 0, 0, 0, 0});  // bit depth, colour type grey, deflate, filter 0, no interlace
  std::vector<std::uint8_t> file{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  put_chunk(file, "IHDR", ihdr);
  put_chunk(file, "IDAT", packed);
  put_chunk(file, "IEND", {});
  return io::write_file_atomic(path, file);
}

}  // namespace gauss
