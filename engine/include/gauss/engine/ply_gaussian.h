#pragma once
// Standard 3DGS PLY scenes (the INRIA layout) read into and written from a GaussianCloud.
//
// Accepted input: "format ascii | binary_little_endian | binary_big_endian 1.0" with one element
// named "vertex" holding
//   x y z                          required
//   nx ny nz                       optional, ignored (trainers write zeros)
//   f_dc_0 f_dc_1 f_dc_2           required
//   f_rest_0 .. f_rest_{n-1}       optional, channel-major; n in {0, 9, 24, 45} gives SH degree 0..3
//   opacity                        required (logit)
//   scale_0 scale_1 scale_2        required (log-scales)
//   rot_0 .. rot_3                 required (w x y z)
//   object_id                      optional (integer, -1 = no object)
//   gaussian_id                    optional (integer, persistent id; must be unique)
//   support                        optional (integer >= 0, observation count)
// Every other property and element is skipped correctly whatever its type (lists included).
// Float properties may be stored as float, double or any integer type; integer properties as
// any integer type, or as float/double holding an exact integer. Types "int64"/"uint64" are
// accepted as an extension (this writer uses "uint64" for gaussian_id only when an id needs
// more than 32 bits).
//
// Normalisation at load (documented, counted in the report):
// - a quaternion whose length differs from 1 by more than kQuaternionUnitTolerance is scaled to
//   unit length; one within the tolerance is kept bit for bit, so loading is idempotent and
//   write -> read of a loaded cloud round-trips bit-exactly;
// - a zero-length quaternion (no rotation defined) becomes the identity (1, 0, 0, 0);
// - an opacity logit of +-Inf (a saturated opacity, as a decoder of 8-bit alphas writes 0
//   and 255) becomes +-ln 509, the logit the 8-bit formats' readers clamp to;
// - a vertex with any other NaN or Inf (a trainer that diverged, a converter's overflow) is
//   left out: its index is listed and the first such value named, and the others keep
//   their file order and ids (the vertex index). A file whose vertices are all left out is
//   an error.
// Everything else wrong is an error naming the input and the element/vertex/property/byte
// offset or line: a missing/duplicated property, a wrong f_rest count,
// a count that disagrees with the data (short or trailing bytes), absurd counts or header
// lines, an out-of-range integer, a repeated gaussian_id. Never a partial cloud.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss {

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

// |length - 1| at or below this counts as unit; float rounding of a normalised quaternion
// stays far inside it (~1e-7), so a normalised quaternion is never normalised twice.
inline constexpr double kQuaternionUnitTolerance = 1e-6;

// What a load found beyond the Gaussians themselves.
struct PlyGaussianReport {
  PlyFormat format{PlyFormat::BinaryLittleEndian};
  std::size_t vertex_count{0};
  int sh_degree{0};
  bool has_normals{false};
  bool has_object_id{false};    // false: every Gaussian's object is kNoObject
  bool has_gaussian_id{false};  // false: ids were set to the vertex index; assign your own
  bool has_support{false};      // false: support is 0
  std::size_t renormalized_quaternions{0};  // non-unit quaternions scaled to unit length
  std::size_t zero_quaternions{0};          // zero-length quaternions replaced by identity
  std::size_t saturated_opacities{0};       // +-Inf opacity logits clamped to +-ln 509
  std::vector<std::size_t> dropped_vertices;  // vertices left out for a non-finite value, ascending
  std::string first_dropped;  // the first such value: "vertex 3, property 'x' (byte offset 580): value is NaN"
  std::vector<std::string> ignored_properties;  // vertex properties skipped (not normals)
  std::vector<std::string> ignored_elements;    // other elements skipped
};

struct PlyGaussianScene {
  GaussianCloud cloud;
  PlyGaussianReport report;
};

// Parses a whole PLY file held in memory; `name` is used in error messages (a path or a label).
Expected<PlyGaussianScene> parse_gaussian_ply(std::span<const std::uint8_t> bytes, std::string_view name);
// Reads and parses a file; errors name the path.
Expected<PlyGaussianScene> read_gaussian_ply(const std::filesystem::path& path);

struct PlyGaussianWriteOptions {
  PlyFormat format{PlyFormat::BinaryLittleEndian};
  bool write_normals{true};       // nx ny nz = 0, as the INRIA trainer writes them
  bool write_object_id{false};    // int
  bool write_gaussian_id{false};  // uint (uint64 when an id exceeds 32 bits)
  bool write_support{false};      // uint
};

// Encodes a cloud as a PLY file image. Fails (naming the Gaussian index and field) on a
// degree outside 0..3 or a non-finite value, which no reader would accept back.
// Coefficients beyond cloud.sh_degree are not written: the degree says what the cloud carries.
// ASCII writes floats in shortest round-trip form, so ascii round trips are bit-exact too.
Expected<std::vector<std::uint8_t>> encode_gaussian_ply(const GaussianCloud& cloud,
                                                        const PlyGaussianWriteOptions& options = {});
// Encodes and writes to `path` through a temporary file renamed into place, so a failed write
// never leaves a truncated file where a good one was.
Status write_gaussian_ply(const std::filesystem::path& path, const GaussianCloud& cloud,
                          const PlyGaussianWriteOptions& options = {});

}  // namespace gauss
