#include "io/ply_core.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <type_traits>
#include <utility>

#include "gauss/engine/log_text.h"

namespace gauss::ply {
namespace {

struct TypeInfo {
  std::string_view name;
  Type type;
};
// Both the classic and the sized names of the PLY spec; int64/uint64 are an extension.
constexpr std::array<TypeInfo, 20> kTypeNames{{
    {"char", Type::Int8},     {"int8", Type::Int8},      {"uchar", Type::UInt8},    {"uint8", Type::UInt8},
    {"short", Type::Int16},   {"int16", Type::Int16},    {"ushort", Type::UInt16},  {"uint16", Type::UInt16},
    {"int", Type::Int32},     {"int32", Type::Int32},    {"uint", Type::UInt32},    {"uint32", Type::UInt32},
    {"float", Type::Float32}, {"float32", Type::Float32}, {"double", Type::Float64}, {"float64", Type::Float64},
    {"int64", Type::Int64},   {"uint64", Type::UInt64},  {"long", Type::Int64},     {"ulong", Type::UInt64},
}};

bool parse_type(std::string_view s, Type& out) {
  for (const auto& t : kTypeNames)
    if (t.name == s) {
      out = t.type;
      return true;
    }
  return false;
}

// Splits a header line on spaces/tabs.
std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

bool printable(std::string_view s) {
  for (char c : s)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) return false;
  return true;
}

// Quoted for messages; control bytes and broken UTF-8 are escaped (escape_for_log) so a
// binary blob cannot garble the text.
std::string quote(std::string_view s) { return "'" + escape_for_log(s, 64) + "'"; }

template <class T>
void store(std::vector<std::uint8_t>& out, T v, bool swap) {
  std::array<std::uint8_t, sizeof(T)> b;
  std::memcpy(b.data(), &v, sizeof(T));
  if (swap)
    for (std::size_t k = 0; k < sizeof(T) / 2; ++k) std::swap(b[k], b[sizeof(T) - 1 - k]);
  out.insert(out.end(), b.begin(), b.end());
}

// Smallest number of bytes one item of `e` can take in `format`: used to reject counts that
// the remaining data cannot possibly hold before anything is allocated or looped over.
std::uint64_t min_item_bytes(const Element& e, PlyFormat format) {
  std::uint64_t n = 0;
  for (const auto& p : e.properties) {
    if (format == PlyFormat::Ascii)
      n += 2;  // one character and one separator or newline per value (a list's count included)
    else
      n += p.is_list ? type_size(p.count_type) : type_size(p.type);
  }
  return n;
}

}  // namespace

std::string format_double(double v) {
  std::array<char, 32> buf;
  std::snprintf(buf.data(), buf.size(), "%.9g", v);
  return buf.data();
}

Error make_error(std::string_view name, const std::string& what) {
  return Error{std::string(name) + ": " + what};
}

std::string_view type_name(Type t) {
  switch (t) {
    case Type::Int8: return "char";
    case Type::UInt8: return "uchar";
    case Type::Int16: return "short";
    case Type::UInt16: return "ushort";
    case Type::Int32: return "int";
    case Type::UInt32: return "uint";
    case Type::Int64: return "int64";
    case Type::UInt64: return "uint64";
    case Type::Float32: return "float";
    case Type::Float64: return "double";
  }
  return "?";
}

int Element::find(std::string_view n) const {
  for (std::size_t k = 0; k < properties.size(); ++k)
    if (properties[k].name == n) return static_cast<int>(k);
  return -1;
}

bool Element::all_scalar() const {
  for (const auto& p : properties)
    if (p.is_list) return false;
  return true;
}

std::size_t Element::scalar_stride() const {
  std::size_t s = 0;
  for (const auto& p : properties) s += type_size(p.type);
  return s;
}

const Element* Header::find(std::string_view n) const {
  for (const auto& e : elements)
    if (e.name == n) return &e;
  return nullptr;
}

Expected<Header> parse_header(std::span<const std::uint8_t> bytes, std::string_view name) {
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  Header h;
  bool have_format = false;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  auto fail = [&](const std::string& what) {
    return make_error(name, "header line " + std::to_string(line_no) + ": " + what);
  };
  while (true) {
    if (pos >= text.size()) {
      if (line_no == 0) return make_error(name, "empty file (not a PLY file)");
      return make_error(name, "truncated header: no 'end_header' line before the end of the file");
    }
    if (pos >= kMaxHeaderBytes)
      return make_error(name, "no 'end_header' within the first " + std::to_string(kMaxHeaderBytes) +
                                  " bytes (header too large or not a PLY file)");
    const std::size_t nl = text.find('\n', pos);
    const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
    ++line_no;
    if (end - pos > kMaxHeaderLineBytes)
      return fail("longer than " + std::to_string(kMaxHeaderLineBytes) + " bytes");
    // Every header line, end_header included, ends with a newline: a line without one is cut off.
    if (nl == std::string_view::npos && line_no > 1)
      return make_error(name, "truncated header: the file ends inside header line " + std::to_string(line_no) +
                                  " (no 'end_header' line)");
    std::string_view line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;

    if (line_no == 1) {
      if (line != "ply") return make_error(name, "not a PLY file: first line is " + quote(line) + ", expected 'ply'");
      continue;
    }
    const auto words = split_words(line);
    if (words.empty()) continue;  // blank header lines carry nothing
    const std::string_view kw = words[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "end_header") {
      if (words.size() != 1) return fail("unexpected text after 'end_header'");
      break;
    }
    if (kw == "format") {
      if (have_format) return fail("second 'format' line");
      if (words.size() != 3) return fail("expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (words[1] == "ascii") h.format = PlyFormat::Ascii;
      else if (words[1] == "binary_little_endian") h.format = PlyFormat::BinaryLittleEndian;
      else if (words[1] == "binary_big_endian") h.format = PlyFormat::BinaryBigEndian;
      else return fail("unsupported format " + quote(words[1]));
      if (words[2] != "1.0") return fail("unsupported format version " + quote(words[2]) + " (only 1.0)");
      have_format = true;
      continue;
    }
    if (kw == "element") {
      if (!have_format) return fail("'element' before the 'format' line");
      if (words.size() != 3) return fail("expected 'element <name> <count>'");
      if (h.elements.size() >= kMaxElements) return fail("more than " + std::to_string(kMaxElements) + " elements");
      if (!printable(words[1])) return fail("element name " + quote(words[1]) + " has non-printable bytes");
      if (h.find(words[1])) return fail("duplicate element " + quote(words[1]));
      std::uint64_t count = 0;
      const auto* b = words[2].data();
      const auto* e = b + words[2].size();
      const auto r = std::from_chars(b, e, count);
      if (r.ec == std::errc::result_out_of_range || (r.ec == std::errc{} && r.ptr == e && count > kMaxElementCount))
        return fail("element " + quote(words[1]) + " count " + std::string(words[2]) + " exceeds the limit of " +
                    std::to_string(kMaxElementCount));
      if (r.ec != std::errc{} || r.ptr != e)
        return fail("element " + quote(words[1]) + " count " + quote(words[2]) + " is not a non-negative integer");
      Element el;
      el.name = std::string(words[1]);
      el.count = count;
      el.header_line = line_no;
      h.elements.push_back(std::move(el));
      continue;
    }
    if (kw == "property") {
      if (h.elements.empty()) return fail("'property' before any 'element'");
      Element& el = h.elements.back();
      if (el.properties.size() >= kMaxPropertiesPerElement)
        return fail("element " + quote(el.name) + " has more than " + std::to_string(kMaxPropertiesPerElement) +
                    " properties");
      Property p;
      p.header_line = line_no;
      if (words.size() >= 2 && words[1] == "list") {
        if (words.size() != 5) return fail("expected 'property list <count type> <item type> <name>'");
        if (!parse_type(words[2], p.count_type)) return fail("unknown list count type " + quote(words[2]));
        if (is_float_type(p.count_type)) return fail("list count type " + quote(words[2]) + " is not an integer type");
        if (!parse_type(words[3], p.type)) return fail("unknown list item type " + quote(words[3]));
        p.is_list = true;
        p.name = std::string(words[4]);
      } else {
        if (words.size() != 3) return fail("expected 'property <type> <name>'");
        if (!parse_type(words[1], p.type))
          return fail("unknown type " + quote(words[1]) + " for property " + quote(words[2]));
        p.name = std::string(words[2]);
      }
      if (!printable(p.name)) return fail("property name " + quote(p.name) + " has non-printable bytes");
      if (el.find(p.name) >= 0)
        return fail("duplicate property " + quote(p.name) + " in element " + quote(el.name));
      el.properties.push_back(std::move(p));
      continue;
    }
    return fail("unknown header keyword " + quote(kw));
  }
  if (!have_format) return make_error(name, "header has no 'format' line");
  h.data_offset = pos;
  h.data_line = line_no + 1;

  // Counts against the bytes that follow: fail fast on absurd counts.
  std::uint64_t remaining = bytes.size() - pos;
  const bool ascii = h.format == PlyFormat::Ascii;
  if (ascii) remaining += 1;  // the last line may lack its newline
  for (const auto& e : h.elements) {
    if (e.count > 0 && e.properties.empty())
      return make_error(name, "element " + quote(e.name) + " (header line " + std::to_string(e.header_line) +
                                  ") declares " + std::to_string(e.count) + " items but no properties");
    const std::uint64_t per = min_item_bytes(e, h.format);
    if (per > 0 && e.count > remaining / per)
      return make_error(name, "element " + quote(e.name) + " declares " + std::to_string(e.count) +
                                  " items of at least " + std::to_string(per) + " bytes each, but only " +
                                  std::to_string(bytes.size() - pos) + " bytes follow the header (byte offset " +
                                  std::to_string(pos) + "): truncated file or wrong count");
    remaining -= e.count * per;
  }
  return h;
}

bool to_double(const Scalar& s, double& out, std::string&) {
  switch (s.type) {
    case Type::Float32: out = s.f; break;
    case Type::Float64: out = s.d; break;
    case Type::Int8: case Type::Int16: case Type::Int32: case Type::Int64: out = static_cast<double>(s.i); break;
    default: out = static_cast<double>(s.u); break;
  }
  return true;
}

namespace {
// Exact integer from a float/double, or false.
bool float_to_int(double d, std::int64_t& out, std::string& why) {
  // 2^63 is exactly representable; anything at or above it does not fit.
  if (!std::isfinite(d) || d != std::floor(d) || d < -9223372036854775808.0 || d >= 9223372036854775808.0) {
    why = "value " + format_double(d) + " is not an integer";
    return false;
  }
  out = static_cast<std::int64_t>(d);
  return true;
}
}  // namespace

bool to_int64(const Scalar& s, std::int64_t& out, std::string& why) {
  switch (s.type) {
    case Type::Float32: return float_to_int(s.f, out, why);
    case Type::Float64: return float_to_int(s.d, out, why);
    case Type::Int8: case Type::Int16: case Type::Int32: case Type::Int64: out = s.i; return true;
    default:
      if (s.u > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
        why = "value " + std::to_string(s.u) + " is too large";
        return false;
      }
      out = static_cast<std::int64_t>(s.u);
      return true;
  }
}

bool to_uint64(const Scalar& s, std::uint64_t& out, std::string& why) {
  switch (s.type) {
    case Type::UInt8: case Type::UInt16: case Type::UInt32: case Type::UInt64: out = s.u; return true;
    case Type::Float64:
      // Doubles hold integers exactly only up to 2^53; beyond that the id would be a guess.
      if (std::isfinite(s.d) && s.d >= 0 && s.d <= 9007199254740992.0 && s.d == std::floor(s.d)) {
        out = static_cast<std::uint64_t>(s.d);
        return true;
      }
      why = "value " + format_double(s.d) + " is not an exact non-negative integer";
      return false;
    default: {
      std::int64_t v = 0;
      if (!to_int64(s, v, why)) return false;
      if (v < 0) {
        why = "negative value " + std::to_string(v);
        return false;
      }
      out = static_cast<std::uint64_t>(v);
      return true;
    }
  }
}

bool BinaryReader::skip_bytes(std::uint64_t count, std::size_t stride) {
  value_start_ = pos_;
  const std::uint64_t avail = bytes_.size() - pos_;
  if (stride > 0 && count > avail / stride) {
    error_ = "data ends at byte offset " + std::to_string(bytes_.size()) + ", " + std::to_string(count) + " items of " +
             std::to_string(stride) + " bytes need " + std::to_string(count * stride) + " bytes from byte offset " +
             std::to_string(pos_);
    return false;
  }
  pos_ += static_cast<std::size_t>(count * stride);
  return true;
}

std::string BinaryReader::trailing() const {
  return std::to_string(bytes_.size() - pos_) + " trailing bytes after the last element (byte offset " +
         std::to_string(pos_) + "): the counts disagree with the data";
}

bool AsciiReader::begin_item() {
  while (pos_ < text_.size()) {
    const std::size_t nl = text_.find('\n', pos_);
    const std::size_t end = nl == std::string_view::npos ? text_.size() : nl;
    line_no_ = next_line_no_++;
    if (end - pos_ > kMaxAsciiLineBytes) {
      error_ = "line " + std::to_string(line_no_) + " is longer than " + std::to_string(kMaxAsciiLineBytes) + " bytes";
      return false;
    }
    line_ = text_.substr(pos_, end - pos_);
    line_pos_ = 0;
    pos_ = nl == std::string_view::npos ? text_.size() : nl + 1;
    if (line_.find_first_not_of(" \t\r") != std::string_view::npos) return true;
  }
  ++line_no_;
  error_ = "file ends at line " + std::to_string(line_no_) + " before all items were read (truncated file or wrong count)";
  return false;
}

bool AsciiReader::next_token(std::string_view& token) {
  while (line_pos_ < line_.size() && (line_[line_pos_] == ' ' || line_[line_pos_] == '\t' || line_[line_pos_] == '\r'))
    ++line_pos_;
  if (line_pos_ >= line_.size()) return false;
  const std::size_t start = line_pos_;
  while (line_pos_ < line_.size() && line_[line_pos_] != ' ' && line_[line_pos_] != '\t' && line_[line_pos_] != '\r')
    ++line_pos_;
  token = line_.substr(start, line_pos_ - start);
  return true;
}

bool AsciiReader::end_item() {
  std::string_view extra;
  if (next_token(extra)) {
    error_ = "unexpected extra value " + quote(extra) + " at the end of line " + std::to_string(line_no_);
    return false;
  }
  return true;
}

bool AsciiReader::read(Type t, Scalar& out) {
  std::string_view tok;
  if (!next_token(tok)) {
    error_ = "line " + std::to_string(line_no_) + " has too few values";
    return false;
  }
  out.type = t;
  const char* b = tok.data();
  const char* e = b + tok.size();
  std::from_chars_result r{};
  switch (t) {
    case Type::Float32: r = std::from_chars(b, e, out.f); break;
    case Type::Float64: r = std::from_chars(b, e, out.d); break;
    case Type::Int8: case Type::Int16: case Type::Int32: case Type::Int64: r = std::from_chars(b, e, out.i); break;
    default: r = std::from_chars(b, e, out.u); break;
  }
  if (r.ec == std::errc::result_out_of_range) {
    error_ = "value " + quote(tok) + " is out of range for type " + std::string(type_name(t));
    return false;
  }
  if (r.ec != std::errc{} || r.ptr != e) {
    error_ = "value " + quote(tok) + " is not a valid " + std::string(type_name(t));
    return false;
  }
  // The sized integer types: from_chars filled the 64-bit field, check the declared range.
  bool in_range = true;
  switch (t) {
    case Type::Int8: in_range = out.i >= -128 && out.i <= 127; break;
    case Type::UInt8: in_range = out.u <= 0xFF; break;
    case Type::Int16: in_range = out.i >= -32768 && out.i <= 32767; break;
    case Type::UInt16: in_range = out.u <= 0xFFFF; break;
    case Type::Int32: in_range = out.i >= std::numeric_limits<std::int32_t>::min() && out.i <= std::numeric_limits<std::int32_t>::max(); break;
    case Type::UInt32: in_range = out.u <= 0xFFFFFFFFull; break;
    default: break;
  }
  if (!in_range) {
    error_ = "value " + quote(tok) + " is out of range for type " + std::string(type_name(t));
    return false;
  }
  return true;
}

bool AsciiReader::at_end() {
  const std::size_t k = text_.find_first_not_of(" \t\r\n", pos_);
  if (k == std::string_view::npos) return true;
  // Count the lines up to the offending byte so the message can name it.
  std::size_t line = next_line_no_;
  for (std::size_t i = pos_; i < k; ++i)
    if (text_[i] == '\n') ++line;
  line_no_ = line;
  return false;
}

template <class Reader>
Status skip_element(Reader& r, const Element& e, std::string_view name) {
  auto fail = [&](std::uint64_t item, const Property* p) {
    std::string what = "element '" + e.name + "' item " + std::to_string(item);
    if (p) what += ", property '" + p->name + "'";
    return make_error(name, what + " (" + r.where() + "): " + r.error());
  };
  if constexpr (std::is_same_v<Reader, BinaryReader>) {
    if (e.all_scalar()) {
      if (!r.skip_bytes(e.count, e.scalar_stride())) return make_error(name, "element '" + e.name + "': " + r.error());
      return Ok{};
    }
  }
  Scalar s;
  std::string why;
  for (std::uint64_t item = 0; item < e.count; ++item) {
    if (!r.begin_item()) return fail(item, nullptr);
    for (const auto& p : e.properties) {
      if (!p.is_list) {
        if (!r.read(p.type, s)) return fail(item, &p);
        continue;
      }
      if (!r.read(p.count_type, s)) return fail(item, &p);
      std::uint64_t n = 0;
      if (!to_uint64(s, n, why))
        return make_error(name, "element '" + e.name + "' item " + std::to_string(item) + ", list '" + p.name +
                                    "' (" + r.where() + "): bad list length: " + why);
      for (std::uint64_t k = 0; k < n; ++k)
        if (!r.read(p.type, s)) return fail(item, &p);
    }
    if (!r.end_item()) return fail(item, nullptr);
  }
  return Ok{};
}

template Status skip_element<BinaryReader>(BinaryReader&, const Element&, std::string_view);
template Status skip_element<AsciiReader>(AsciiReader&, const Element&, std::string_view);

void write_header(std::string& out, PlyFormat format, const std::vector<Element>& elements, std::string_view comment) {
  out += "ply\nformat ";
  out += format == PlyFormat::Ascii ? "ascii" : format == PlyFormat::BinaryBigEndian ? "binary_big_endian"
                                                                                      : "binary_little_endian";
  out += " 1.0\n";
  if (!comment.empty()) {
    out += "comment ";
    out += comment;
    out += '\n';
  }
  for (const auto& e : elements) {
    out += "element " + e.name + " " + std::to_string(e.count) + "\n";
    for (const auto& p : e.properties) {
      out += "property ";
      if (p.is_list) {
        out += "list ";
        out += type_name(p.count_type);
        out += ' ';
      }
      out += type_name(p.type);
      out += ' ';
      out += p.name;
      out += '\n';
    }
  }
  out += "end_header\n";
}

void put_float(std::vector<std::uint8_t>& out, float v, bool big_endian) { store(out, v, needs_swap(big_endian)); }
void put_u8(std::vector<std::uint8_t>& out, std::uint8_t v) { out.push_back(v); }
void put_i32(std::vector<std::uint8_t>& out, std::int32_t v, bool big_endian) { store(out, v, needs_swap(big_endian)); }
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v, bool big_endian) { store(out, v, needs_swap(big_endian)); }
void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v, bool big_endian) { store(out, v, needs_swap(big_endian)); }

namespace {
template <class T>
void put_chars(std::string& out, T v) {
  std::array<char, 64> buf;
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  out.append(buf.data(), r.ptr);
}
}  // namespace

void put_text(std::string& out, float v) { put_chars(out, v); }
void put_text(std::string& out, std::int64_t v) { put_chars(out, v); }
void put_text(std::string& out, std::uint64_t v) { put_chars(out, v); }

}  // namespace gauss::ply
