#pragma once
// Private to the codec: 128-bit little-endian bit packing of the fixed record, the
// record read/write shared by quantize.cpp and the batch codec, LEB128 varints, and the
// LSB-first bit stream with order-k exponential-Golomb codes the batch's columns use.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
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
  // The first `bytes` bytes (the record is kRecordBytesSh0 = 15 of them).
  void store(std::uint8_t* out, int bytes) const {
    for (int i = 0; i < bytes; ++i) out[i] = static_cast<std::uint8_t>(w_[i / 8] >> (8 * (i % 8)));
  }

 private:
  std::uint64_t w_[2] = {0, 0};
  int pos_ = 0;
};

class BitReader128 {
 public:
  BitReader128(const std::uint8_t* in, int bytes) {
    for (int i = 0; i < bytes; ++i) w_[i / 8] |= std::uint64_t{in[i]} << (8 * (i % 8));
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
// 6-bit support code (codec.h states the bound).
std::uint8_t support_code(std::uint32_t support, CodecStats* stats);
std::uint32_t dequantize_support(std::uint8_t code);

inline void put_varint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<std::uint8_t>(v | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<std::uint8_t>(v));
}

// ---- bit stream ---------------------------------------------------------------------
// Bits are appended LSB-first into bytes (bit i of the stream is bit i % 8 of byte i / 8).

class BitStreamWriter {
 public:
  explicit BitStreamWriter(std::vector<std::uint8_t>& out) : out_(out) {}
  // Appends the low `bits` bits of v (0 <= bits <= 64).
  void put(std::uint64_t v, int bits) {
    while (bits > 0) {
      const int take = std::min(bits, 32);
      const std::uint64_t chunk = v & ((std::uint64_t{1} << take) - 1);
      acc_ |= chunk << fill_;
      fill_ += take;
      while (fill_ >= 8) {
        out_.push_back(static_cast<std::uint8_t>(acc_));
        acc_ >>= 8;
        fill_ -= 8;
      }
      v = take < 64 ? v >> take : 0;
      bits -= take;
    }
  }
  // Order-k exponential-Golomb code of v (0 <= k <= 63): with x = v + 2^k and n = the
  // index of x's top bit, n - k zero bits, a one bit, then x's n low bits. 2n - k + 1 bits;
  // x may need 65 bits (v >= 2^64 - 2^k), then n = 64 and the low bits are x mod 2^64.
  void put_eg(std::uint64_t v, int k) {
    const std::uint64_t base = std::uint64_t{1} << k;
    const std::uint64_t x = v + base;  // wraps exactly when n = 64
    const int n = x < v ? 64 : std::bit_width(x) - 1;
    put(0, n - k);
    put(1, 1);
    put(x, n);
  }
  // Zero bits up to the next byte boundary.
  void align() {
    if (fill_ > 0) {
      out_.push_back(static_cast<std::uint8_t>(acc_));
      acc_ = 0;
      fill_ = 0;
    }
  }

 private:
  std::vector<std::uint8_t>& out_;
  std::uint64_t acc_ = 0;
  int fill_ = 0;
};

// Bits an order-k exponential-Golomb code of v takes (as BitStreamWriter::put_eg writes).
inline std::uint64_t eg_bits(std::uint64_t v, int k) {
  const std::uint64_t x = v + (std::uint64_t{1} << k);
  const int n = x < v ? 64 : std::bit_width(x) - 1;
  return static_cast<std::uint64_t>(2 * n - k + 1);
}

// The k in [0, 40] that codes `values` in the fewest bits, and that size.
template <class Values>
std::pair<int, std::uint64_t> best_eg_order(const Values& values) {
  // Histogram of bit widths: a code's length depends on v only through bit_width(v + 2^k),
  // which is max(bit_width(v), k + 1) or one more when adding 2^k carries; the carry is
  // counted from the histogram's upper bound, so the choice is near-optimal, never wrong
  // (any k decodes).
  std::uint64_t hist[65] = {};
  for (std::uint64_t v : values) ++hist[std::bit_width(v)];
  int best_k = 0;
  std::uint64_t best = ~std::uint64_t{0};
  for (int k = 0; k <= 40; ++k) {
    std::uint64_t bits = 0;
    for (int b = 0; b <= 64; ++b) {
      if (hist[b] == 0) continue;
      const std::uint64_t top = b == 0 ? 0 : (b == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << b) - 1);
      bits += hist[b] * eg_bits(top, k);
    }
    if (bits < best) {
      best = bits;
      best_k = k;
    }
  }
  return {best_k, best};
}

// Reads what BitStreamWriter wrote; every read is bounds-checked, and a failed read
// leaves ok() false (the caller reports the byte offset).
class BitStreamReader {
 public:
  explicit BitStreamReader(std::span<const std::uint8_t> bytes) : b_(bytes) {}
  std::size_t byte_offset() const { return static_cast<std::size_t>(pos_ / 8); }
  std::uint64_t bits_left() const { return 8 * static_cast<std::uint64_t>(b_.size()) - pos_; }
  bool get(int bits, std::uint64_t& v) {
    v = 0;
    if (static_cast<std::uint64_t>(bits) > bits_left()) return false;
    for (int done = 0; done < bits;) {
      const std::size_t byte = static_cast<std::size_t>(pos_ / 8);
      const int shift = static_cast<int>(pos_ % 8);
      const int take = std::min(8 - shift, bits - done);
      const std::uint64_t chunk = (std::uint64_t{b_[byte]} >> shift) & ((1u << take) - 1);
      v |= chunk << done;
      done += take;
      pos_ += static_cast<std::uint64_t>(take);
    }
    return true;
  }
  // An order-k exponential-Golomb code; false when truncated or when the value would
  // not fit 64 bits (a hostile prefix of more than 64 - k zeros, or n = 64 with low bits
  // at or above 2^k).
  bool get_eg(int k, std::uint64_t& v) {
    int zeros = 0;
    for (;;) {
      std::uint64_t bit = 0;
      if (!get(1, bit)) return false;
      if (bit) break;
      if (++zeros > 64 - k) return false;
    }
    const int n = zeros + k;
    std::uint64_t low = 0;
    if (!get(n, low)) return false;
    const std::uint64_t base = std::uint64_t{1} << k;
    if (n == 64) {
      if (low >= base) return false;
      v = low - base;  // 2^64 + low - 2^k, computed mod 2^64: exact as it is < 2^64
      return true;
    }
    v = (std::uint64_t{1} << n) + low - base;
    return true;
  }
  // The rest of the current byte must be zero padding (one canonical encoding).
  bool align() {
    const int rest = static_cast<int>((8 - pos_ % 8) % 8);
    std::uint64_t pad = 0;
    return get(rest, pad) && pad == 0;
  }

 private:
  std::span<const std::uint8_t> b_;
  std::uint64_t pos_ = 0;
};

inline std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
inline std::int64_t unzigzag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

}  // namespace gauss::codec_detail
