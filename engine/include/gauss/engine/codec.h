#pragma once
// Edit-batch codec: quantised compact Gaussian records, batched and zstd-compressed.
//
// A Gaussian crosses the wire as a fixed 15-byte record (SH degree 0) plus 3 bytes per
// higher SH coefficient at the scene's degree; its id, object id and support travel in
// bit-packed columns beside the records (a few bits each, often less than one: see the
// layout below). Quantisation ranges come from CodecParams, which host and client share
// for a session, so a Gaussian quantises to the same record in every batch:
// quantize_roundtrip() is exactly what the client sees and the differ can compare
// records to skip no-op updates.
//
// 15-byte record (120 bits), bit-packed little-endian (fields LSB-first, widths below).
// Version 1 had 16 bytes (15-bit positions, 9-bit rotation components, 8-bit opacity,
// 7+8+7-bit colour); the bits were taken where the measured render error grew least
// (gauss-bench host: quantised vs float PSNR on the synthetic room, guitar and
// fruit_drops; a 7-bit log-scale instead cost fruit_drops 6 dB, to 44.5 dB):
//   position   3 x 14 bits, uniform in params.box
//   rotation   2 + 3 x 8 bits, smallest-three (index of the dropped largest component,
//              the other three in [-1/sqrt2, 1/sqrt2], sign fixed so the largest is >= 0)
//   log-scale  3 x 8 bits, uniform in [log_scale_min, log_scale_max]
//   opacity    7 bits, uniform in sigmoid space [0, 1]
//   SH0 colour 3 x 7 bits, uniform in [dc_min, dc_max]
// SH rest: 8 bits per coefficient and channel, uniform in [-sh_rest_abs_max, +sh_rest_abs_max].
//
// Decode error bounds for in-range finite input (tested in tests/engine/test_codec_*.cpp):
//   position   |err| <= 0.5 * (box.max - box.min) / (2^14 - 1) per axis
//   log-scale  |err| <= 0.5 * (log_scale_max - log_scale_min) / 255
//   opacity    |sigmoid err| <= 0.5 / 127
//   SH0        |err| <= 0.5 * (dc_max - dc_min) / 127
//   SH rest    |err| <= 0.5 * 2 * sh_rest_abs_max / 254 (254 steps so 0 is exact)
//   rotation   unit quaternion; max component error (up to sign) <= kRotationMaxError
//              (254 steps per component so the identity is exact)
//   support    6-bit code c = round(4 log2(1 + s)): |log2(1 + s') - log2(1 + s)| <= 1/8
//              before s' is rounded to an integer, i.e. (1 + s) is off by at most
//              2^(1/8) - 1 (~9.1 %) plus 0.5; 0..7 are exact; saturates at kMaxSupport
//              (counted). Support only orders the client's progressive publication, so
//              the coarse code costs no image quality.
//   id, object id, epoch, edit kinds: exact
// Out-of-range input is clamped to the nearest representable value and counted in
// CodecStats (never wrapped); non-finite values are replaced (position: box centre,
// others: range midpoint / identity rotation) and counted.
//
// Wire layout of the uncompressed payload, version 2:
//   "GAEB" | u8 version | u8 sh_degree | varint epoch |
//   varint n_remove | varint n_replace | varint n_update | varint n_insert |   (LEB128)
//   bit stream, LSB-first; EG_k(v) is the order-k exponential-Golomb code of v (2n-k+1
//   bits, n = index of the top bit of v + 2^k), k a 6-bit field chosen by the encoder:
//     for each of remove, replace, update, insert ids (sorted ascending) with n > 0:
//       k, then EG_k(first id), EG_k(id - previous id - 1) for the others
//     replace leaving ids (n_replace > 0): k, EG_k(zigzag(leaving - previous leaving))
//     the value edits (replace, update, insert, in that order), when there are any:
//       object ids as runs of equal ids: EG_0(runs - 1), k_len, k_obj, then per run
//         EG_k_len(length - 1), EG_k_obj(zigzag(object - previous run's object))
//       support codes: 1 bit mode; 0: 6 bits per edit; 1: runs, as the object ids
//         (EG_0(runs - 1), k_len, k_code, EG_k_len(length - 1), EG_k_code(zigzag(delta)))
//       (the encoder picks the shorter mode)
//     zero bits up to the next byte (a decoder rejects non-zero padding)
//   records              (15 + 3 * sh_rest_count(sh_degree) bytes each, value-edit order)
// So an SH0 Gaussian costs 15 bytes plus ~1 bit of id when ids are consecutive, ~4 when
// one in five is sent, and its share of the object and support runs (6 bits at most
// for support). gauss-bench host prints the figures.
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
  bool operator==(const CodecBox&) const = default;
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
  bool operator==(const CodecParams&) const = default;
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

inline constexpr int kCodecVersion = 2;
// zstd level 1. Measured with `gauss-bench host` at version 2 (bytes per Gaussian after
// zstd, 100k-200k inserts; raw 15.15): synthetic room SH0 8.00 (level 3: 7.71, level 9:
// 7.20), SH1 7.28 (7.25), 200k SH0 6.93 (6.50); real guitar.ply 14.98 at levels 1-9 (the
// record bits are incompressible; raw 15.13). Level 1 ran ~2x faster than level 3 for
// at most 7 % more bytes.
inline constexpr int kZstdLevel = 1;
inline constexpr int kPositionBits = 14;
inline constexpr int kRotationBits = 8;
inline constexpr int kLogScaleBits = 8;
inline constexpr int kOpacityBits = 7;
inline constexpr int kDcBits = 7;
inline constexpr int kShRestBits = 8;
inline constexpr std::size_t kRecordBytesSh0 = 15;
static_assert(3 * kPositionBits + 2 + 3 * kRotationBits + 3 * kLogScaleBits + kOpacityBits + 3 * kDcBits ==
                  8 * kRecordBytesSh0,
              "the SH0 record's fields fill its bytes exactly");
// Support code: c = round(kSupportCodeSteps * log2(1 + s)) in kSupportCodeBits bits.
inline constexpr int kSupportCodeBits = 6;
inline constexpr int kSupportCodeSteps = 4;
inline constexpr std::uint32_t kMaxSupportCode = (1u << kSupportCodeBits) - 1;
// Largest decoded support, round(2^(63/4) - 1); input whose code would pass 63 (support
// above ~60,100) is clamped and counted.
inline constexpr std::uint32_t kMaxSupport = 55108;
inline constexpr double kRotationMaxError = 0.013;
// Largest decoded payload accepted: 1M value edits at SH3 (60 B + ids) fit; a header that
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
// A live scene's params (a followed snapshot folder, a capture replayed frame by frame):
// fitted to its first epoch, the box widened by kLiveBoxMargin of its extent on every side,
// since later epochs may reach beyond it (positions beyond clamp, and the codec counts them).
// The host and gauss-eval both use it, so they quantise a live scene alike.
inline constexpr float kLiveBoxMargin = 0.25f;
CodecParams fit_live_codec_params(std::span<const Gaussian> first_epoch, int sh_degree);

// Checks params are usable (finite, min < max, degree 0..3).
Status validate_codec_params(const CodecParams& params);

// The record bytes a Gaussian quantises to (record_bytes(params.sh_degree) bytes,
// written to out).
void quantize_record(const Gaussian& g, const CodecParams& params, std::uint8_t* out, CodecStats* stats = nullptr);

// A record as it was sent, kept compactly (the differ's memory of what a client holds): the
// quantised record bytes, then the object id (4 bytes) and the support code (1 byte).
constexpr std::size_t sent_record_bytes(int sh_degree) { return record_bytes(sh_degree) + 5; }
// Writes g's sent record (sent_record_bytes(params.sh_degree) bytes, every one of them) to
// out. Two Gaussians reach the client alike exactly when their sent records are equal.
void write_sent_record(const Gaussian& g, const CodecParams& params, std::uint8_t* out);
// The Gaussian a client decodes from it, id `id`: equal to quantize_roundtrip of the record
// written.
Gaussian read_sent_record(const std::uint8_t* in, GaussianId id, const CodecParams& params);

// What the client sees for g: quantised and dequantised (id, object kept; carrier false).
Gaussian quantize_roundtrip(const Gaussian& g, const CodecParams& params);

// Uncompressed payload (the layout above). Stats accumulate when given.
// `sent_records`, when given and no stats are: the sent record (write_sent_record with these
// params) of each Replace, Update and Insert edit, in the batch's order (what
// Differ::last_sent_records holds for the batch it made); the records, object ids and support
// codes are then copied from them instead of quantised again, and the payload is the same. Any other
// size is ignored. Stats count clamps and non-finite values as they are quantised, so with
// stats every record is.
std::vector<std::uint8_t> encode_edit_batch_raw(const EditBatch& batch, const CodecParams& params,
                                                CodecStats* stats = nullptr,
                                                std::span<const std::uint8_t> sent_records = {});
Expected<EditBatch> decode_edit_batch_raw(std::span<const std::uint8_t> payload, const CodecParams& params);

// zstd-compressed payload: what goes on the wire. `sent_records` as for encode_edit_batch_raw.
std::vector<std::uint8_t> encode_edit_batch(const EditBatch& batch, const CodecParams& params,
                                            CodecStats* stats = nullptr,
                                            std::span<const std::uint8_t> sent_records = {});
// The same payload from a batch of edit headers and the sent record of each of its Replace,
// Update and Insert edits, in its order (Differ::diff_headers, last_sent_records): the bytes
// encode_edit_batch gives for the full batch with those records. Fails when the records are
// not exactly that many.
Expected<std::vector<std::uint8_t>> encode_edit_headers(const EditHeaderBatch& batch, const CodecParams& params,
                                                        std::span<const std::uint8_t> sent_records);
// Hostile-input safe: never crashes, never allocates more than kMaxPayloadBytes plus the
// counts the payload can actually hold; errors name the byte offset and what is wrong.
Expected<EditBatch> decode_edit_batch(std::span<const std::uint8_t> bytes, const CodecParams& params);

}  // namespace gauss
