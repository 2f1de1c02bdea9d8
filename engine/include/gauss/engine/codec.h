#pragma once
// Edit-batch codec: quantised compact Gaussian records, batched and zstd-compressed.
//
// A Gaussian crosses the wire as a fixed 16-byte record (SH degree 0) plus 3 bytes per
// higher SH coefficient at the scene's degree, plus an id (delta varint), an object id
// (zigzag delta varint) and a 1-byte log-quantised support. Quantisation ranges come
// from CodecParams, which host and client share for a session, so a Gaussian quantises
// to the same record in every batch: quantize_roundtrip() is exactly what the client sees
// and the differ can compare records to skip no-op updates.
//
// 16-byte record, bit-packed little-endian into two 64-bit words (widths below):
//   position   3 x 15 bits, uniform in params.box
//   rotation   2 + 3 x 9 bits, smallest-three (index of the dropped largest component,
//              the other three in [-1/sqrt2, 1/sqrt2], sign fixed so the largest is >= 0)
//   log-scale  3 x 8 bits, uniform in [log_scale_min, log_scale_max]
//   opacity    8 bits, uniform in sigmoid space [0, 1]
//   SH0 colour 7 + 8 + 7 bits (R, G, B), uniform in [dc_min, dc_max]; green carries most
//              luminance so it gets the spare bit
// SH rest: 8 bits per coefficient and channel, uniform in [-sh_rest_abs_max, +sh_rest_abs_max].
//
// Decode error bounds for in-range finite input (tested in tests/engine/test_codec_*.cpp):
//   position   |err| <= 0.5 * (box.max - box.min) / (2^15 - 1) per axis
//   log-scale  |err| <= 0.5 * (log_scale_max - log_scale_min) / 255
//   opacity    |sigmoid err| <= 0.5 / 255
//   SH0        |err| <= 0.5 * (dc_max - dc_min) / (2^bits - 1), bits = 7 (R, B) or 8 (G)
//   SH rest    |err| <= 0.5 * 2 * sh_rest_abs_max / 254 (254 steps so 0 is exact)
//   rotation   unit quaternion; max component error (up to sign) <= kRotationMaxError
//              (510 steps per component so the identity is exact)
//   support    code round(16 log2(1 + s)) in 8 bits: relative error of (1 + s) <= 2^(1/32) - 1
//              (~2.2 %), small counts exact; saturates at kMaxSupport (counted)
//   id, object id, epoch, edit kinds: exact
// Out-of-range input is clamped to the nearest representable value and counted in
// CodecStats (never wrapped); non-finite values are replaced (position: box centre,
// others: range midpoint / identity rotation) and counted.
//
// Wire layout of the uncompressed payload (all varints are LEB128, unsigned):
//   "GAEB" | u8 version | u8 sh_degree | varint epoch |
//   varint n_remove | varint n_replace | varint n_update | varint n_insert |
//   remove ids           (sorted ascending, delta varints)
//   replace ids          (sorted ascending, delta varints) then their leaving ids (zigzag delta varints)
//   update ids, insert ids (each sorted ascending, delta varints)
//   object ids for replace+update+insert (zigzag delta varints, in that order)
//   support bytes        (one per replace+update+insert)
//   records              (16 + 3 * sh_rest_count(sh_degree) bytes each, same order)
// The compressed batch is one zstd frame (level kZstdLevel) with its content size set.
// Decoded batches hold removes, then replaces, updates, inserts, each sorted by id: the
// client can free slots before it fills them. A batch names each id at most once.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/edit.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss {

struct CodecBox {
  glm::vec3 min{-10.0f};
  glm::vec3 max{10.0f};
};

struct CodecParams {
  CodecBox box{};
  int sh_degree{0};  // 0..3: SH rest is carried only up to this degree
  // Log-scale quantiser range. A 3DGS scene's log-scales rarely leave [-10, 1]
  // (45 um .. 2.7 m); fit_codec_params() narrows it to the scene for finer steps.
  float log_scale_min{-10.0f};
  float log_scale_max{1.0f};
  // SH0 range: colour = 0.5 + 0.2821 * dc, so [-1.8, 1.8] spans colours [-0.01, 1.01].
  float dc_min{-1.8f};
  float dc_max{1.8f};
  // SH rest coefficients are quantised symmetrically in [-abs_max, abs_max].
  float sh_rest_abs_max{1.0f};
};

// Counts of values the encoder could not represent exactly (clamped or replaced).
struct CodecStats {
  std::uint64_t position_clamped{0};   // components outside params.box
  std::uint64_t log_scale_clamped{0};  // components outside [log_scale_min, log_scale_max]
  std::uint64_t dc_clamped{0};         // SH0 components outside [dc_min, dc_max]
  std::uint64_t sh_rest_clamped{0};    // SH rest components beyond +-sh_rest_abs_max
  std::uint64_t support_clamped{0};    // support above kMaxSupport (the 8-bit code saturates)
  std::uint64_t non_finite{0};         // NaN/Inf components replaced (any field)
  std::uint64_t gaussians{0};          // records encoded
  std::uint64_t raw_bytes{0};          // payload bytes before zstd (sum over batches)
  std::uint64_t compressed_bytes{0};   // bytes after zstd (sum over batches)

  std::uint64_t clamped_total() const {
    return position_clamped + log_scale_clamped + dc_clamped + sh_rest_clamped + support_clamped + non_finite;
  }
};

inline constexpr int kCodecVersion = 1;
// zstd level 1. Measured with `gauss-bench host` (bytes per Gaussian after zstd, 100k-200k
// inserts): synthetic room SH0 8.67 (level 3: 8.49, level 9: 8.17), SH1 8.10 (level 3:
// 8.29), 200k SH0 7.65 (7.40); real guitar.ply 16.00 at levels 1-9 (the record bits are
// incompressible; zstd removes the id/object/support columns). Level 1 ran 1.5-4x faster
// than level 3 for at most 3 % more bytes.
inline constexpr int kZstdLevel = 1;
inline constexpr int kPositionBits = 15;
inline constexpr int kRotationBits = 9;
inline constexpr int kLogScaleBits = 8;
inline constexpr int kOpacityBits = 8;
inline constexpr int kDcBitsRB = 7;
inline constexpr int kDcBitsG = 8;
inline constexpr int kShRestBits = 8;
inline constexpr std::size_t kRecordBytesSh0 = 16;
// Largest decoded support, round(2^(255/16) - 1); input whose code would pass 255 (support
// above ~64,130) is clamped and counted.
inline constexpr std::uint32_t kMaxSupport = 62756;
inline constexpr double kRotationMaxError = 0.0065;
// Largest decoded payload accepted: 1M value edits at SH3 (61 B + ids) fit; a header that
// declares more is rejected before any allocation.
inline constexpr std::size_t kMaxPayloadBytes = std::size_t{96} << 20;

// Most edits one batch may hold: a full swap of the largest client (400k slots out, 400k
// in) plus updates fits; a header asking for more is rejected before anything is decoded,
// which bounds the decoded batch (~270 B per edit) whatever the payload says.
inline constexpr std::size_t kMaxBatchEdits = std::size_t{1} << 20;

constexpr std::size_t record_bytes(int sh_degree) {
  return kRecordBytesSh0 + 3 * static_cast<std::size_t>(sh_rest_count(sh_degree));
}

// Fits box (bounds of the finite positions, padded by 1 %), log-scale, SH0 and SH rest
// ranges to a scene so its values use the quantisers' full resolution. Box and log-scales
// take the exact range (clamping the largest Gaussians is the most visible error); SH0 and
// SH rest cover the 0.05 %..99.95 % quantiles, so a few colour outliers are clamped rather
// than stretching the steps for everyone. Empty input gives the defaults with the degree.
CodecParams fit_codec_params(std::span<const Gaussian> gaussians, int sh_degree);

// Checks params are usable (finite, min < max, degree 0..3).
Status validate_codec_params(const CodecParams& params);

// The record bytes a Gaussian quantises to (record_bytes(params.sh_degree) bytes,
// written to out). The differ hashes these to detect a changed record.
void quantize_record(const Gaussian& g, const CodecParams& params, std::uint8_t* out, CodecStats* stats = nullptr);
// 64-bit hash of the quantised record, object id and quantised support.
std::uint64_t quantized_hash(const Gaussian& g, const CodecParams& params);

// What the client sees for g: quantised and dequantised (id, object kept; carrier false).
Gaussian quantize_roundtrip(const Gaussian& g, const CodecParams& params);

// Uncompressed payload (the layout above). Stats accumulate when given.
std::vector<std::uint8_t> encode_edit_batch_raw(const EditBatch& batch, const CodecParams& params,
                                                CodecStats* stats = nullptr);
Expected<EditBatch> decode_edit_batch_raw(std::span<const std::uint8_t> payload, const CodecParams& params);

// zstd-compressed payload: what goes on the wire.
std::vector<std::uint8_t> encode_edit_batch(const EditBatch& batch, const CodecParams& params,
                                            CodecStats* stats = nullptr);
// Hostile-input safe: never crashes, never allocates more than kMaxPayloadBytes plus the
// counts the payload can actually hold; errors name the byte offset and what is wrong.
Expected<EditBatch> decode_edit_batch(std::span<const std::uint8_t> bytes, const CodecParams& params);

}  // namespace gauss
