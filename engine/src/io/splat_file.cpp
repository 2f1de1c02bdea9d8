// Format detection and dispatch for splat scene files (splat_file.h).
#include "gauss/engine/splat_file.h"

#include <algorithm>
#include <cctype>
#include <new>
#include <string>
#include <system_error>

#include "gauss/engine/ply_gaussian.h"
#include "io/file_bytes.h"

namespace gauss {
namespace {

bool starts_with(std::span<const std::uint8_t> bytes, std::string_view magic) {
  return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin(),
                                                    [](char c, std::uint8_t b) { return static_cast<std::uint8_t>(c) == b; });
}

// The PLY header, or empty when "end_header" is not within the first 64 KiB.
std::string_view ply_header(std::span<const std::uint8_t> bytes) {
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), std::min<std::size_t>(bytes.size(), 65536));
  const std::size_t end = text.find("end_header");
  return end == std::string_view::npos ? std::string_view{} : text.substr(0, end);
}

bool has_word(std::string_view header, std::string_view word) {
  for (std::size_t at = header.find(word); at != std::string_view::npos; at = header.find(word, at + 1)) {
    const bool left = at == 0 || header[at - 1] == ' ';
    const std::size_t after = at + word.size();
    const bool right = after == header.size() || header[after] == '\n' || header[after] == '\r' || header[after] == ' ';
    if (left && right) return true;
  }
  return false;
}

std::string lower_extension(std::string_view name) {
  std::string ext = std::filesystem::path(std::string(name)).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

SplatScene from_ply(PlyGaussianScene scene) {
  SplatScene out;
  out.report.format = SplatFormat::InriaPly;
  out.report.count = scene.cloud.gaussians.size();
  out.report.sh_degree = scene.cloud.sh_degree;
  out.report.has_object_id = scene.report.has_object_id;
  out.report.has_gaussian_id = scene.report.has_gaussian_id;
  out.report.renormalized_quaternions = scene.report.renormalized_quaternions;
  out.report.zero_quaternions = scene.report.zero_quaternions;
  out.report.saturated_opacities = scene.report.saturated_opacities;
  out.report.dropped = std::move(scene.report.dropped_vertices);
  out.report.first_dropped = std::move(scene.report.first_dropped);
  out.cloud = std::move(scene.cloud);
  return out;
}

}  // namespace

std::vector<std::string> splat_load_notes(const SplatFileReport& report) {
  std::vector<std::string> notes;
  if (!report.dropped.empty())
    notes.push_back("left out " + std::to_string(report.dropped.size()) + " of " +
                    std::to_string(report.count + report.dropped.size()) +
                    " Gaussians with a non-finite value (the first: " + report.first_dropped + ")");
  if (report.saturated_opacities > 0)
    notes.push_back(std::to_string(report.saturated_opacities) +
                    " opacity logits of +-Inf taken as +-6.23 (opacity 1 or 0 within half an 8-bit step)");
  return notes;
}

std::string_view to_string(SplatFormat format) {
  switch (format) {
    case SplatFormat::InriaPly: return "inria-ply";
    case SplatFormat::CompressedPly: return "compressed-ply";
    case SplatFormat::AntimatterSplat: return "splat";
    case SplatFormat::Spz: return "spz";
    case SplatFormat::Sog: return "sog";
  }
  return "unknown";
}

Expected<SplatFormat> detect_splat_format(std::span<const std::uint8_t> bytes, std::string_view name) {
  const std::string who(name);
  if (starts_with(bytes, "ply\n") || starts_with(bytes, "ply\r\n")) {
    const std::string_view header = ply_header(bytes);
    if (header.empty()) return Error{who + ": a PLY whose header has no end_header within 64 KiB"};
    if (has_word(header, "packed_position")) return SplatFormat::CompressedPly;
    if (has_word(header, "f_dc_0")) return SplatFormat::InriaPly;
    return Error{who + ": a PLY without 3DGS properties (neither f_dc_0 nor a compressed chunk/packed_position layout)"};
  }
  // SPZ: a gzip stream (versions 2-3), or the NGSP magic in the clear (version 4 on).
  if (starts_with(bytes, "\x1f\x8b") || starts_with(bytes, "NGSP")) return SplatFormat::Spz;
  if (starts_with(bytes, "PK\x03\x04")) return SplatFormat::Sog;
  if (lower_extension(name) == ".splat") {
    if (bytes.size() % 32 != 0)
      return Error{who + ": a .splat file must hold 32-byte records, but its " + std::to_string(bytes.size()) +
                   " bytes are not a multiple of 32"};
    return SplatFormat::AntimatterSplat;
  }
  std::string what = "nothing recognised";
  if (bytes.empty()) what = "an empty file";
  else if (starts_with(bytes, "{")) what = "text starting with '{' (a SOG meta.json? give its folder or the .sog zip)";
  return Error{who + ": not a splat scene (" + what +
               "; expected a 3DGS PLY, PlayCanvas compressed PLY, .splat, SPZ or SOG)"};
}

Expected<SplatScene> parse_splat_file(std::span<const std::uint8_t> bytes, std::string_view name) {
  auto format = detect_splat_format(bytes, name);
  if (!format) return format.error();
  switch (*format) {
    case SplatFormat::InriaPly: {
      auto ply = parse_gaussian_ply(bytes, name);
      if (!ply) return ply.error();
      return from_ply(std::move(*ply));
    }
    case SplatFormat::CompressedPly: return parse_compressed_ply(bytes, name);
    case SplatFormat::AntimatterSplat: return parse_antimatter_splat(bytes, name);
    case SplatFormat::Spz: return parse_spz(bytes, name);
    case SplatFormat::Sog: return parse_sog_zip(bytes, name);
  }
  return Error{std::string(name) + ": unhandled splat format"};
}

Expected<SplatScene> read_splat_file(const std::filesystem::path& path, std::atomic<std::uint64_t>* bytes_read) {
  // The readers ask for room before their large allocations (io/memory_room.h); anything
  // smaller that fails anyway is the same error, not an exception through the caller (a
  // viewer's loading thread, a host's followed folder).
  try {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return read_sog_folder(path);
    if (path.filename() == "meta.json") return read_sog_folder(path.parent_path());
    auto bytes = io::read_file_bytes(path, bytes_read);
    if (!bytes) return bytes.error();
    return parse_splat_file(*bytes, path.string());
  } catch (const std::bad_alloc&) {
    return Error{path.string() + ": not enough memory to read it"};
  }
}

}  // namespace gauss
