#pragma once
// Little-endian byte writer/reader shared by the wire encoders and decoders
// (private to engine/src/wire). The reader stops at the first problem and keeps
// one error naming the message, the field and the byte offset, so a decoder is a
// straight sequence of reads followed by one ok() check.
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss::wire::detail {

class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}

  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void vec3(const glm::vec3& v) { f32(v.x); f32(v.y); f32(v.z); }
  void vec4(const glm::vec4& v) { f32(v.x); f32(v.y); f32(v.z); f32(v.w); }
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    out_.insert(out_.end(), s.begin(), s.end());
  }
  void bytes(std::span<const std::uint8_t> b) {
    u32(static_cast<std::uint32_t>(b.size()));
    out_.insert(out_.end(), b.begin(), b.end());
  }
  void raw(std::span<const std::uint8_t> b) { out_.insert(out_.end(), b.begin(), b.end()); }
  std::size_t size() const { return out_.size(); }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t>& out_;
};

class Reader {
 public:
  Reader(std::span<const std::uint8_t> bytes, const char* message) : b_(bytes), message_(message) {}

  bool ok() const { return error_.empty(); }
  Error error() const { return Error{error_}; }
  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return b_.size() - pos_; }

  // Records the first failure; later reads become no-ops that return false.
  bool fail(const char* field, const std::string& what) { return fail_at(field, pos_, what); }
  bool fail_at(const char* field, std::size_t at, const std::string& what) {
    if (error_.empty())
      error_ = std::string(message_) + ": field '" + field + "' at byte " + std::to_string(at) + ": " + what;
    return false;
  }

  bool u8(const char* f, std::uint8_t& v) {
    std::uint64_t x = 0;
    if (!get(f, 1, x)) return false;
    v = static_cast<std::uint8_t>(x);
    return true;
  }
  bool u16(const char* f, std::uint16_t& v) {
    std::uint64_t x = 0;
    if (!get(f, 2, x)) return false;
    v = static_cast<std::uint16_t>(x);
    return true;
  }
  bool u32(const char* f, std::uint32_t& v) {
    std::uint64_t x = 0;
    if (!get(f, 4, x)) return false;
    v = static_cast<std::uint32_t>(x);
    return true;
  }
  bool u64(const char* f, std::uint64_t& v) { return get(f, 8, v); }
  bool i32(const char* f, std::int32_t& v) {
    std::uint32_t x = 0;
    if (!u32(f, x)) return false;
    v = static_cast<std::int32_t>(x);
    return true;
  }
  // Floats must be finite: no field of the schema has a meaning for NaN or Inf.
  bool f32(const char* f, float& v) {
    const std::size_t at = pos_;
    std::uint32_t x = 0;
    if (!u32(f, x)) return false;
    v = std::bit_cast<float>(x);
    if (!std::isfinite(v)) return fail_at(f, at, "not a finite number");
    return true;
  }
  bool vec3(const char* f, glm::vec3& v) { return f32(f, v.x) && f32(f, v.y) && f32(f, v.z); }
  bool vec4(const char* f, glm::vec4& v) { return f32(f, v.x) && f32(f, v.y) && f32(f, v.z) && f32(f, v.w); }

  // A u32 element count, bounded by the schema maximum and by the bytes left
  // (each element needs at least `min_elem_bytes`), checked BEFORE any reserve so
  // a forged count can never allocate more than the message carries.
  bool count(const char* f, std::uint32_t& n, std::size_t max, std::size_t min_elem_bytes) {
    const std::size_t at = pos_;
    if (!u32(f, n)) return false;
    if (n > max) return fail_at(f, at, "count " + std::to_string(n) + " exceeds limit " + std::to_string(max));
    if (min_elem_bytes > 0 && n > remaining() / min_elem_bytes)
      return fail_at(f, at, "count " + std::to_string(n) + " needs more bytes than the " +
                                std::to_string(remaining()) + " left");
    return true;
  }
  bool str(const char* f, std::string& s, std::size_t max) {
    std::uint32_t n = 0;
    if (!count(f, n, max, 1)) return false;
    s.assign(reinterpret_cast<const char*>(b_.data() + pos_), n);
    pos_ += n;
    return true;
  }
  bool bytes(const char* f, std::vector<std::uint8_t>& out, std::size_t max) {
    std::uint32_t n = 0;
    if (!count(f, n, max, 1)) return false;
    out.assign(b_.begin() + static_cast<std::ptrdiff_t>(pos_), b_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return true;
  }
  // A view of the next n bytes (n already validated by the caller via count()).
  bool view(const char* f, std::size_t n, std::span<const std::uint8_t>& out) {
    if (!ok()) return false;
    if (n > remaining()) return fail(f, "needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) + " left");
    out = b_.subspan(pos_, n);
    pos_ += n;
    return true;
  }
  // The body must be consumed exactly: trailing bytes mean a different schema.
  bool finish() {
    if (!ok()) return false;
    if (pos_ != b_.size()) return fail("<end>", std::to_string(b_.size() - pos_) + " trailing bytes");
    return true;
  }

 private:
  bool get(const char* f, int n, std::uint64_t& v) {
    if (!ok()) return false;
    if (remaining() < static_cast<std::size_t>(n))
      return fail(f, "truncated: needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) + " left");
    v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(b_[pos_ + static_cast<std::size_t>(i)]) << (8 * i);
    pos_ += static_cast<std::size_t>(n);
    return true;
  }

  std::span<const std::uint8_t> b_;
  const char* message_;
  std::size_t pos_{0};
  std::string error_;
};

// Semantic checks shared by encoder (refuse to write) and decoder (refuse to read).
inline Error field_error(const char* message, const std::string& field, const std::string& what) {
  return Error{std::string(message) + ": field '" + field + "': " + what};
}
using gauss::finite3;
inline bool finite4(const glm::vec4& v) { return finite3(glm::vec3(v)) && std::isfinite(v.w); }

}  // namespace gauss::wire::detail
