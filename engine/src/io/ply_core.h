#pragma once
// PLY container layer shared by the Gaussian and mesh readers/writers: header parsing with
// hard caps, scalar types, and two value readers (binary, ascii) with the same interface so
// element decoders are written once as templates. Private to engine/.
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gauss/engine/ply_gaussian.h"  // PlyFormat
#include "gauss/engine/result.h"

namespace gauss::ply {

// Caps that make hostile headers fail fast instead of allocating or looping.
inline constexpr std::size_t kMaxHeaderLineBytes = 4096;
inline constexpr std::size_t kMaxHeaderBytes = 1 << 20;
inline constexpr std::size_t kMaxPropertiesPerElement = 4096;
inline constexpr std::size_t kMaxElements = 256;
inline constexpr std::size_t kMaxAsciiLineBytes = 1 << 20;
// Items per element: mesh indices and Gaussian slots are 32-bit.
inline constexpr std::uint64_t kMaxElementCount = 0xFFFFFFFFull;

// A double for messages: %.9g, so 1e-300 does not print as "0.000000" nor 1e300 as 300 digits.
std::string format_double(double v);

// Whether data in the given byte order must be byte-swapped on this machine.
constexpr bool needs_swap(bool big_endian) { return big_endian != (std::endian::native == std::endian::big); }

enum class Type : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64 };

constexpr std::size_t type_size(Type t) {
  switch (t) {
    case Type::Int8: case Type::UInt8: return 1;
    case Type::Int16: case Type::UInt16: return 2;
    case Type::Int32: case Type::UInt32: case Type::Float32: return 4;
    case Type::Int64: case Type::UInt64: case Type::Float64: return 8;
  }
  return 0;
}
std::string_view type_name(Type t);  // the canonical PLY name ("float", "uchar", ...)
inline bool is_float_type(Type t) { return t == Type::Float32 || t == Type::Float64; }

struct Property {
  std::string name;
  Type type{Type::Float32};     // item type for lists
  bool is_list{false};
  Type count_type{Type::UInt8}; // lists only
  std::size_t header_line{0};
};

struct Element {
  std::string name;
  std::uint64_t count{0};
  std::vector<Property> properties;
  std::size_t header_line{0};

  // Index of the property called `name`, or -1.
  int find(std::string_view name) const;
  bool all_scalar() const;
  std::size_t scalar_stride() const;  // bytes per item when all_scalar()
};

struct Header {
  PlyFormat format{PlyFormat::BinaryLittleEndian};
  std::vector<Element> elements;
  std::size_t data_offset{0};  // first byte after "end_header\n"
  std::size_t data_line{0};    // 1-based line number of the first data line (ascii)

  const Element* find(std::string_view name) const;
};

// Parses and sanity-checks the header: magic, format, elements, properties (no duplicates),
// caps, and that the data after the header is long enough for every declared count (so a
// 10^12-item header fails here). Errors are prefixed with `name`.
Expected<Header> parse_header(std::span<const std::uint8_t> bytes, std::string_view name);

// One value as stored, in its widest natural form.
struct Scalar {
  Type type{Type::Float32};
  float f{0.0f};
  double d{0.0};
  std::int64_t i{0};
  std::uint64_t u{0};
};

// Conversions used by the decoders. They return false with `why` set when the value does not
// fit (a float target accepts any finite value; integer targets need an exact integer in range).
bool to_double(const Scalar& s, double& out, std::string& why);
bool to_int64(const Scalar& s, std::int64_t& out, std::string& why);
bool to_uint64(const Scalar& s, std::uint64_t& out, std::string& why);

// Binary value reader. Every read is bounds checked; `where()` names the byte offset of the
// last value started.
class BinaryReader {
 public:
  BinaryReader(std::span<const std::uint8_t> bytes, std::size_t offset, bool big_endian)
      : bytes_(bytes), pos_(offset), swap_(needs_swap(big_endian)) {}

  bool begin_item() { return true; }
  bool end_item() { return true; }
  bool read(Type t, Scalar& out);
  // Skips `count` fixed-size items without decoding them (false when the data is short).
  bool skip_bytes(std::uint64_t count, std::size_t stride);
  std::string where() const { return "byte offset " + std::to_string(value_start_); }
  const std::string& error() const { return error_; }
  // Trailing-data check after the last element.
  bool at_end() const { return pos_ == bytes_.size(); }
  std::string trailing() const;

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t pos_;
  std::size_t value_start_{0};
  bool swap_;
  std::string error_;
};

// ASCII value reader: one item per line, values separated by spaces/tabs. Blank lines
// between items are skipped. `where()` names the line.
class AsciiReader {
 public:
  AsciiReader(std::span<const std::uint8_t> bytes, std::size_t offset, std::size_t first_line)
      : text_(reinterpret_cast<const char*>(bytes.data()), bytes.size()), pos_(offset), next_line_no_(first_line) {}

  bool begin_item();  // moves to the next non-blank line (false at end of data)
  bool end_item();    // false when values remain on the line
  bool read(Type t, Scalar& out);
  std::string where() const { return "line " + std::to_string(line_no_); }
  const std::string& error() const { return error_; }
  bool at_end();  // only whitespace remains
  std::string trailing() const { return "unexpected data after the last element at " + where(); }

 private:
  bool next_token(std::string_view& token);
  std::string_view text_;
  std::size_t pos_;
  std::size_t next_line_no_;
  std::size_t line_no_{0};
  std::string_view line_;
  std::size_t line_pos_{0};
  std::string error_;
};

template <class T>
inline T load(const std::uint8_t* p, bool swap) {
  std::array<std::uint8_t, sizeof(T)> b;
  std::memcpy(b.data(), p, sizeof(T));
  if (swap)
    for (std::size_t k = 0; k < sizeof(T) / 2; ++k) std::swap(b[k], b[sizeof(T) - 1 - k]);
  T v;
  std::memcpy(&v, b.data(), sizeof(T));
  return v;
}

// Inline: these run once per value, so the decoders' loops must see through them.
inline bool BinaryReader::read(Type t, Scalar& out) {
  value_start_ = pos_;
  const std::size_t n = type_size(t);
  if (bytes_.size() - pos_ < n) {
    error_ = "file ends at byte offset " + std::to_string(bytes_.size()) + " in the middle of a " +
             std::string(type_name(t)) + " value (truncated file or wrong count)";
    return false;
  }
  const std::uint8_t* p = bytes_.data() + pos_;
  out.type = t;
  switch (t) {
    case Type::Int8: out.i = static_cast<std::int8_t>(p[0]); break;
    case Type::UInt8: out.u = p[0]; break;
    case Type::Int16: out.i = load<std::int16_t>(p, swap_); break;
    case Type::UInt16: out.u = load<std::uint16_t>(p, swap_); break;
    case Type::Int32: out.i = load<std::int32_t>(p, swap_); break;
    case Type::UInt32: out.u = load<std::uint32_t>(p, swap_); break;
    case Type::Int64: out.i = load<std::int64_t>(p, swap_); break;
    case Type::UInt64: out.u = load<std::uint64_t>(p, swap_); break;
    case Type::Float32: out.f = load<float>(p, swap_); break;
    case Type::Float64: out.d = load<double>(p, swap_); break;
  }
  pos_ += n;
  return true;
}

inline bool to_float(const Scalar& s, float& out, std::string& why) {
  switch (s.type) {
    case Type::Float32: out = s.f; break;
    case Type::Float64:
      // Checked before the cast: a finite double beyond float's range has no float value.
      if (std::isfinite(s.d) && std::abs(s.d) > double(std::numeric_limits<float>::max())) {
        why = "double value " + format_double(s.d) + " is outside the float range";
        return false;
      }
      out = static_cast<float>(s.d);
      break;
    case Type::Int8: case Type::Int16: case Type::Int32: case Type::Int64: out = static_cast<float>(s.i); break;
    default: out = static_cast<float>(s.u); break;
  }
  return true;
}

// Reads (and drops) every item of an element, lists included, so the next element starts at
// the right place. Errors name the element, item and position.
template <class Reader>
Status skip_element(Reader& r, const Element& e, std::string_view name);

// Appends a header for `elements` (only names/types/counts are used) in `format`.
void write_header(std::string& out, PlyFormat format, const std::vector<Element>& elements,
                  std::string_view comment);

// Binary value writer helpers: append a value of the given type in the given byte order.
void put_float(std::vector<std::uint8_t>& out, float v, bool big_endian);
void put_u8(std::vector<std::uint8_t>& out, std::uint8_t v);
void put_i32(std::vector<std::uint8_t>& out, std::int32_t v, bool big_endian);
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v, bool big_endian);
void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v, bool big_endian);
// ASCII helpers: shortest round-trip text (std::to_chars), no separator.
void put_text(std::string& out, float v);
void put_text(std::string& out, std::int64_t v);
void put_text(std::string& out, std::uint64_t v);

Error make_error(std::string_view name, const std::string& what);


}  // namespace gauss::ply
