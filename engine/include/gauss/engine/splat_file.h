#pragma once
// Splat scene files in the formats people have, read into a GaussianCloud.
//
// Each reader turns its file into the trainer's own parameterisation (log-scales, opacity
// logit, SH coefficients, unit quaternion w x y z), so everything downstream is format-blind.
// The formats that quantise say how in their reader's comment; a reader never returns a
// partial cloud, and NaN/Inf never leave it: where a format stores floats per Gaussian (the
// INRIA PLY, .splat), a Gaussian with a non-finite value is left out and listed in the report
// (its file index; the others keep theirs as ids, kept_file_indices.h), an infinite opacity
// logit is clamped. Errors name the input and, for truncations and impossible counts, the
// byte offset where the data stops making sense.
//
//   InriaPly       the 3DGS trainer's PLY (ply_gaussian.h)
//   CompressedPly  PlayCanvas compressed PLY: 256-splat chunks with min/max bounds, packed
//                  32-bit position/rotation/scale/colour words, optional 8-bit SH
//   AntimatterSplat  antimatter15 .splat: 32 bytes per splat, no header
//   Spz            Niantic SPZ (gzip-wrapped or not), versions 2..4
//   Sog            PlayCanvas SOG: meta.json + WebP images, zipped or as a folder
//
// Detection is by content (magic bytes, the PLY header's properties, a zip's entries);
// only the headerless .splat relies on its extension plus a size that is a whole number of
// records.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss {

enum class SplatFormat : std::uint8_t { InriaPly, CompressedPly, AntimatterSplat, Spz, Sog };

// "inria-ply", "compressed-ply", "splat", "spz", "sog".
std::string_view to_string(SplatFormat format);

struct SplatFileReport {
  SplatFormat format{SplatFormat::InriaPly};
  std::uint32_t version{0};  // SPZ / SOG version; 0 where the format has none
  std::size_t count{0};      // Gaussians read
  int sh_degree{0};
  bool has_object_id{false};    // per-Gaussian object ids came from the file (INRIA PLY only today)
  bool has_gaussian_id{false};  // persistent ids came from the file; otherwise ids are the index
  std::size_t renormalized_quaternions{0};
  std::size_t zero_quaternions{0};
  std::size_t saturated_opacities{0};  // +-Inf opacity logits clamped to +-ln 509 (INRIA PLY)
  // Gaussians left out for a non-finite value: their indices in the file, ascending, and the
  // first such value as text. `count` is what was kept.
  std::vector<std::size_t> dropped;
  std::string first_dropped;
  bool antialiased{false};  // trained with antialiasing (SPZ's flag; render with the matching filter)
};

struct SplatScene {
  GaussianCloud cloud;
  SplatFileReport report;
};

// What a person should hear about a load beyond its count: Gaussians left out, opacities
// clamped ("left out 3 of 90857 Gaussians with a non-finite value (the first: vertex 0,
// ...)"), one line each; none when the file was clean.
std::vector<std::string> splat_load_notes(const SplatFileReport& report);

// Which format a file image is, from its content (`name` supplies the extension the
// headerless .splat needs, and the error message). An unknown file's error says what was
// recognised (e.g. "a PLY without 3DGS properties", "a zip without meta.json").
Expected<SplatFormat> detect_splat_format(std::span<const std::uint8_t> bytes, std::string_view name);

// Parses a whole file image in any format above.
Expected<SplatScene> parse_splat_file(std::span<const std::uint8_t> bytes, std::string_view name);

// Reads a file in any format above, or a SOG folder (a folder holding meta.json, or the
// meta.json itself). Errors name the path. `bytes_read`, when given, counts the file's
// bytes as they are read (in 4 MiB pieces; a SOG folder's are not counted): the parsers
// report nothing, so that is the progress a viewer can show (scene_load.h).
Expected<SplatScene> read_splat_file(const std::filesystem::path& path, std::atomic<std::uint64_t>* bytes_read = nullptr);

// The per-format parsers behind parse_splat_file (each one's header comment is in its .cpp).
Expected<SplatScene> parse_compressed_ply(std::span<const std::uint8_t> bytes, std::string_view name);
Expected<SplatScene> parse_antimatter_splat(std::span<const std::uint8_t> bytes, std::string_view name);
Expected<SplatScene> parse_spz(std::span<const std::uint8_t> bytes, std::string_view name);
Expected<SplatScene> parse_sog_zip(std::span<const std::uint8_t> bytes, std::string_view name);
Expected<SplatScene> read_sog_folder(const std::filesystem::path& folder);

}  // namespace gauss
