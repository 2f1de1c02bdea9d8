#pragma once
// Private to the codec: 128-bit little-endian bit packing of the fixed record, the
// record read/write shared by quantize.cpp and the batch codec, and LEB128 varints.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gauss/engine/codec.h"

namespace gauss::codec_detail {

// Packs fields LSB-first into two 64-bit words; the record is those words stored
// little-endian, so the layout does not depend on the host's byte order.
class BitWriter128 {
 public:
  void put(std::uint32_t value, int bits) {
    const std::uint64_t v = value & ((std::uint64_t{1} << bits) - 1);
    if (pos_ >= 64) {
      w_[1] |= v << (pos_ - 64);
    } else if (pos_ + bits <= 64) {
      w_[0] |= v << pos_;
    } else {
      w_[0] |= v << pos_;
      w_[1] |= v >> (64 - pos_);
    }
    pos_ += bits;
  }
  void store(std::uint8_t* out) const {
    for (int i = 0; i < 16; ++i) out[i] = static_cast<std::uint8_t>(w_[i / 8] >> (8 * (i % 8)));
  }

 private:
  std::uint64_t w_[2] = {0, 0};
  int pos_ = 0;
};

class BitReader128 {
 public:
  explicit BitReader128(const std::uint8_t* in) {
    for (int i = 0; i < 16; ++i) w_[i / 8] |= std::uint64_t{in[i]} << (8 * (i % 8));
  }
  std::uint32_t get(int bits) {
    const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
    std::uint64_t v;
    if (pos_ >= 64) {
      v = w_[1] >> (pos_ - 64);
    } else if (pos_ + bits <= 64) {
      v = w_[0] >> pos_;
    } else {
      v = (w_[0] >> pos_) | (w_[1] << (64 - pos_));
    }
    pos_ += bits;
    return static_cast<std::uint32_t>(v & mask);
  }

 private:
  std::uint64_t w_[2] = {0, 0};
  int pos_ = 0;
};

void write_record(const Gaussian& g, const CodecParams& p, std::uint8_t* out, CodecStats* stats);
void read_record(const std::uint8_t* in, const CodecParams& p, Gaussian& g);
std::uint8_t support_code(std::uint32_t support, CodecStats* stats);
std::uint32_t dequantize_support(std::uint8_t code);

inline void put_varint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<std::uint8_t>(v | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<std::uint8_t>(v));
}

inline std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
inline std::int64_t unzigzag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

}  // namespace gauss::codec_detail
