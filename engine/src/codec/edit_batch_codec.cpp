// Edit batches on the wire: columnar payload (ids, object ids, support, records) and
// its zstd frame. The layout is documented in gauss/engine/codec.h.
#include <algorithm>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>

#include <zstd.h>

#include "codec/record_bits.h"
#include "gauss/engine/codec.h"

namespace gauss {
namespace {

using codec_detail::put_varint;
using codec_detail::unzigzag;
using codec_detail::zigzag;

constexpr std::uint8_t kMagic[4] = {'G', 'A', 'E', 'B'};

// Edits (Edit or EditHeader) grouped in wire order: removes, replaces, updates, inserts, each by id.
template <class E>
struct Grouped {
  std::vector<const E*> group[4];
};

int wire_group(EditKind k) {
  switch (k) {
    case EditKind::Remove: return 0;
    case EditKind::Replace: return 1;
    case EditKind::Update: return 2;
    case EditKind::Insert: return 3;
  }
  return 3;
}

using codec_detail::BitStreamReader;
using codec_detail::BitStreamWriter;
using codec_detail::best_eg_order;
using codec_detail::eg_bits;

// 6-bit field holding an exponential-Golomb order.
constexpr int kOrderBits = 6;

// Values of one column coded with the order that makes them shortest.
void put_eg_column(BitStreamWriter& w, const std::vector<std::uint64_t>& values) {
  const int k = best_eg_order(values).first;
  w.put(static_cast<std::uint64_t>(k), kOrderBits);
  for (std::uint64_t v : values) w.put_eg(v, k);
}

// Sorted ids as gaps: the first id itself, then id - previous - 1 (0 for consecutive ids,
// so a run of them costs one bit each at order 0).
template <class E>
void put_sorted_ids(BitStreamWriter& w, const std::vector<const E*>& edits, std::vector<std::uint64_t>& scratch) {
  if (edits.empty()) return;
  scratch.clear();
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < edits.size(); ++i) {
    const std::uint64_t id = to_underlying(edits[i]->id);
    // A repeated id (which a batch must not hold) gives 2^64 - 1: the decoder rejects it.
    scratch.push_back(i == 0 ? id : id - prev - 1);
    prev = id;
  }
  put_eg_column(w, scratch);
}

// Runs of equal values: (length - 1, zigzag delta of the value from the previous run's).
struct Runs {
  std::vector<std::uint64_t> lengths;
  std::vector<std::uint64_t> deltas;
};

Runs make_runs(const std::vector<std::int64_t>& values) {
  Runs r;
  std::int64_t prev = 0;
  for (std::size_t i = 0; i < values.size();) {
    std::size_t j = i + 1;
    while (j < values.size() && values[j] == values[i]) ++j;
    r.lengths.push_back(j - i - 1);
    r.deltas.push_back(zigzag(values[i] - prev));
    prev = values[i];
    i = j;
  }
  return r;
}

std::uint64_t runs_bits(const Runs& r) {
  return eg_bits(r.lengths.size() - 1, 0) + 2 * kOrderBits + best_eg_order(r.lengths).second +
         best_eg_order(r.deltas).second;
}

void put_runs(BitStreamWriter& w, const Runs& r) {
  w.put_eg(r.lengths.size() - 1, 0);
  const int k_len = best_eg_order(r.lengths).first;
  const int k_val = best_eg_order(r.deltas).first;
  w.put(static_cast<std::uint64_t>(k_len), kOrderBits);
  w.put(static_cast<std::uint64_t>(k_val), kOrderBits);
  for (std::size_t i = 0; i < r.lengths.size(); ++i) {
    w.put_eg(r.lengths[i], k_len);
    w.put_eg(r.deltas[i], k_val);
  }
}

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> b) : b_(b) {}
  std::size_t offset() const { return off_; }
  std::size_t remaining() const { return b_.size() - off_; }
  bool varint(std::uint64_t& v) {
    v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (off_ >= b_.size()) return false;
      const std::uint8_t byte = b_[off_++];
      if (shift == 63 && (byte & 0x7E) != 0) return false;  // more than 64 bits
      v |= std::uint64_t{byte & 0x7Fu} << shift;
      if ((byte & 0x80) == 0) return true;
    }
    return false;
  }
  bool bytes(std::size_t n, const std::uint8_t*& p) {
    if (n > remaining()) return false;
    p = b_.data() + off_;
    off_ += n;
    return true;
  }

 private:
  std::span<const std::uint8_t> b_;
  std::size_t off_ = 0;
};

Error decode_error(std::size_t offset, const std::string& what) {
  return Error{"edit batch: byte " + std::to_string(offset) + ": " + what};
}

}  // namespace

namespace {

// The raw payload of `edits` (Edit or EditHeader). Headers carry no values: their records,
// object ids and support codes come from `sent_records`, which the caller has checked.
template <class E>
std::vector<std::uint8_t> encode_raw(std::span<const E> edits, Epoch epoch, const CodecParams& params,
                                     CodecStats* stats, std::span<const std::uint8_t> sent_records) {
  constexpr bool kHeaders = std::is_same_v<E, EditHeader>;
  Grouped<E> g;
  for (const E& e : edits) g.group[wire_group(e.kind)].push_back(&e);
  auto by_id = [](const E* a, const E* b) { return to_underlying(a->id) < to_underlying(b->id); };
  for (auto& grp : g.group)  // a Differ's batch comes sorted
    if (!std::is_sorted(grp.begin(), grp.end(), by_id)) std::sort(grp.begin(), grp.end(), by_id);
  const int degree = std::clamp(params.sh_degree, 0, kMaxShDegree);
  const std::size_t rec = record_bytes(degree);
  const std::size_t n_values = g.group[1].size() + g.group[2].size() + g.group[3].size();
  // The value edits' sent records, when given for exactly these edits: record bytes, then
  // the object id (4 bytes), then the support code (sent_record_bytes).
  const std::size_t sent_stride = sent_record_bytes(degree);
  const bool copy_records = kHeaders || (!stats && n_values > 0 && sent_records.size() == n_values * sent_stride);
  std::vector<std::uint32_t> value_index;  // edit -> its place among the value edits
  if (copy_records) {
    value_index.resize(edits.size());
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < edits.size(); ++i)
      if (edits[i].kind != EditKind::Remove) value_index[i] = v++;
  }
  auto sent_of = [&](const E* e) {
    return sent_records.data() + std::size_t{value_index[std::size_t(e - edits.data())]} * sent_stride;
  };

  std::vector<std::uint8_t> out;
  out.reserve(32 + (g.group[0].size() + 2 * g.group[1].size()) / 2 + n_values * (rec + 2));
  for (std::uint8_t m : kMagic) out.push_back(m);
  out.push_back(static_cast<std::uint8_t>(kCodecVersion));
  out.push_back(static_cast<std::uint8_t>(degree));
  put_varint(out, to_underlying(epoch));
  for (const auto& grp : g.group) put_varint(out, grp.size());

  BitStreamWriter w(out);
  std::vector<std::uint64_t> scratch;
  put_sorted_ids(w, g.group[0], scratch);
  put_sorted_ids(w, g.group[1], scratch);
  if (!g.group[1].empty()) {
    scratch.clear();
    std::uint64_t prev_leaving = 0;
    for (const E* e : g.group[1]) {
      const std::uint64_t id = to_underlying(e->leaving);
      scratch.push_back(zigzag(static_cast<std::int64_t>(id - prev_leaving)));  // wraps on purpose: exact inverse
      prev_leaving = id;
    }
    put_eg_column(w, scratch);
  }
  put_sorted_ids(w, g.group[2], scratch);
  put_sorted_ids(w, g.group[3], scratch);

  if (n_values > 0) {
    std::vector<std::int64_t> objects;
    std::vector<std::int64_t> support;
    objects.reserve(n_values);
    support.reserve(n_values);
    for (int k = 1; k < 4; ++k) {
      for (const E* e : g.group[k]) {
        if (copy_records) {
          std::int32_t object;  // the sent record's object id, then its support code (write_sent_record)
          std::memcpy(&object, sent_of(e) + rec, 4);
          objects.push_back(object);
          support.push_back(sent_of(e)[rec + 4]);
        } else if constexpr (!kHeaders) {
          objects.push_back(to_underlying(e->value.object));
          support.push_back(codec_detail::support_code(e->value.support, stats));
        }
      }
    }
    put_runs(w, make_runs(objects));
    // Support: whichever of fixed 6-bit codes and runs is shorter (uniform support, e.g.
    // a PLY without it, costs next to nothing; varied support at most 6 bits).
    const Runs support_runs = make_runs(support);
    const bool use_runs = runs_bits(support_runs) < n_values * static_cast<std::uint64_t>(kSupportCodeBits);
    w.put(use_runs ? 1 : 0, 1);
    if (use_runs) {
      put_runs(w, support_runs);
    } else {
      for (std::int64_t c : support) w.put(static_cast<std::uint64_t>(c), kSupportCodeBits);
    }
  }
  w.align();

  const std::size_t rec_start = out.size();
  out.resize(rec_start + n_values * rec);
  std::uint8_t* r = out.data() + rec_start;
  for (int k = 1; k < 4; ++k) {
    for (const E* e : g.group[k]) {
      if (copy_records)
        std::memcpy(r, sent_of(e), rec);
      else if constexpr (!kHeaders)
        codec_detail::write_record(e->value, params, r, stats);
      r += rec;
    }
  }
  if (stats) {
    stats->gaussians += n_values;
    stats->raw_bytes += out.size();
  }
  return out;
}

std::vector<std::uint8_t> compress_payload(const std::vector<std::uint8_t>& raw, CodecStats* stats) {
  std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), kZstdLevel);
  // Compressing into a ZSTD_compressBound-sized buffer cannot fail except on allocation
  // failure inside zstd; an empty result then makes the receiver reject the batch.
  out.resize(ZSTD_isError(n) ? 0 : n);
  if (stats) stats->compressed_bytes += out.size();
  return out;
}

}  // namespace

std::vector<std::uint8_t> encode_edit_batch_raw(const EditBatch& batch, const CodecParams& params,
                                                CodecStats* stats, std::span<const std::uint8_t> sent_records) {
  return encode_raw<Edit>(batch.edits, batch.epoch, params, stats, sent_records);
}

Expected<std::vector<std::uint8_t>> encode_edit_headers(const EditHeaderBatch& batch, const CodecParams& params,
                                                        std::span<const std::uint8_t> sent_records) {
  const std::size_t values =
      std::size_t(std::count_if(batch.edits.begin(), batch.edits.end(), [](const EditHeader& e) { return e.kind != EditKind::Remove; }));
  const std::size_t stride = sent_record_bytes(std::clamp(params.sh_degree, 0, kMaxShDegree));
  if (sent_records.size() != values * stride)
    return Error{"encode_edit_headers: " + std::to_string(sent_records.size()) + " bytes of sent records for " +
                 std::to_string(values) + " value edits of " + std::to_string(stride) + " bytes each"};
  return compress_payload(encode_raw<EditHeader>(batch.edits, batch.epoch, params, nullptr, sent_records), nullptr);
}

Expected<EditBatch> decode_edit_batch_raw(std::span<const std::uint8_t> payload, const CodecParams& params) {
  if (Status st = validate_codec_params(params); !st) return st.error();
  if (payload.size() > kMaxPayloadBytes) {
    return decode_error(0, "payload of " + std::to_string(payload.size()) + " bytes exceeds the limit");
  }
  Reader rd(payload);
  const std::uint8_t* head = nullptr;
  if (!rd.bytes(6, head)) return decode_error(0, "truncated header (need 6 bytes)");
  if (std::memcmp(head, kMagic, 4) != 0) return decode_error(0, "bad magic (not an edit batch)");
  if (head[4] != kCodecVersion) {
    return decode_error(4, "unsupported version " + std::to_string(head[4]));
  }
  if (head[5] != params.sh_degree) {
    return decode_error(5, "SH degree " + std::to_string(head[5]) + " differs from the session's " +
                               std::to_string(params.sh_degree));
  }
  EditBatch batch;
  std::uint64_t v = 0;
  if (!rd.varint(v)) return decode_error(rd.offset(), "truncated or overlong epoch varint");
  batch.epoch = Epoch{v};
  std::uint64_t n[4];
  for (auto& c : n) {
    const std::size_t at = rd.offset();
    if (!rd.varint(c)) return decode_error(at, "truncated or overlong edit count");
    // Every edit costs at least one payload bit, so a count beyond the payload's bits is
    // a lie: reject it before reserving anything (and before the sums below can wrap).
    if (c > 8 * payload.size()) return decode_error(at, "edit count " + std::to_string(c) + " exceeds payload size");
  }
  const std::size_t rec = record_bytes(params.sh_degree);
  const std::uint64_t n_values = n[1] + n[2] + n[3];
  if (n[0] + n_values > kMaxBatchEdits) {
    return decode_error(rd.offset(), std::to_string(n[0] + n_values) + " edits exceed the limit of " +
                                         std::to_string(kMaxBatchEdits) + " per batch");
  }
  // Each id (and leaving id) needs >= 1 bit, each value edit its record: a count the
  // payload cannot hold is rejected before anything is allocated.
  if (n_values * rec + (n[0] + 2 * n[1] + n[2] + n[3] + 7) / 8 > rd.remaining()) {
    return decode_error(rd.offset(), "edit counts need more bytes than the payload holds");
  }
  batch.edits.resize(static_cast<std::size_t>(n[0] + n_values));

  const EditKind kinds[4] = {EditKind::Remove, EditKind::Replace, EditKind::Update, EditKind::Insert};
  std::size_t first[4];
  {
    std::size_t at = 0;
    for (int k = 0; k < 4; ++k) {
      first[k] = at;
      at += static_cast<std::size_t>(n[k]);
    }
  }
  const std::size_t bits_start = rd.offset();
  BitStreamReader bits(payload.subspan(bits_start));
  auto bit_error = [&](const std::string& what) { return decode_error(bits_start + bits.byte_offset(), what); };
  auto read_order = [&](int& k) {
    std::uint64_t order = 0;
    if (!bits.get(kOrderBits, order)) return false;
    k = static_cast<int>(order);
    return true;
  };
  auto read_ids = [&](int g) -> Status {
    if (n[g] == 0) return Ok{};
    int k = 0;
    if (!read_order(k)) return Status(bit_error("truncated id column"));
    std::uint64_t prev = 0;
    for (std::uint64_t i = 0; i < n[g]; ++i) {
      std::uint64_t d = 0;
      if (!bits.get_eg(k, d)) return Status(bit_error("truncated or overlong id code"));
      std::uint64_t id = d;
      if (i > 0) {
        // id = prev + d + 1 must fit 64 bits.
        if (d >= std::numeric_limits<std::uint64_t>::max() - prev) return Status(bit_error("id gap overflows 64 bits"));
        id = prev + d + 1;
      }
      prev = id;
      Edit& e = batch.edits[first[g] + static_cast<std::size_t>(i)];
      e.kind = kinds[g];
      e.id = GaussianId{id};
    }
    return Ok{};
  };
  if (Status st = read_ids(0); !st) return st.error();
  if (Status st = read_ids(1); !st) return st.error();
  if (n[1] > 0) {
    int k = 0;
    if (!read_order(k)) return bit_error("truncated leaving-id column");
    std::uint64_t prev_leaving = 0;
    for (std::uint64_t i = 0; i < n[1]; ++i) {
      if (!bits.get_eg(k, v)) return bit_error("truncated or overlong leaving-id code");
      prev_leaving += static_cast<std::uint64_t>(unzigzag(v));
      batch.edits[first[1] + static_cast<std::size_t>(i)].leaving = GaussianId{prev_leaving};
    }
  }
  if (Status st = read_ids(2); !st) return st.error();
  if (Status st = read_ids(3); !st) return st.error();

  const std::size_t values_begin = first[1];
  const std::size_t values_end = batch.edits.size();
  // Runs of equal values over the value edits; `apply(i, delta)` takes the run's value
  // from the previous run's and the zigzag-decoded delta, or fails with a reason.
  auto read_runs = [&](const char* what, auto&& apply) -> Status {
    std::uint64_t runs_minus_1 = 0;
    int k_len = 0;
    int k_val = 0;
    if (!bits.get_eg(0, runs_minus_1) || !read_order(k_len) || !read_order(k_val)) {
      return Status(bit_error(std::string("truncated ") + what + " runs"));
    }
    if (runs_minus_1 >= values_end - values_begin) {
      return Status(bit_error(std::string("more ") + what + " runs than value edits"));
    }
    std::size_t i = values_begin;
    for (std::uint64_t r = 0; r <= runs_minus_1; ++r) {
      std::uint64_t len_minus_1 = 0;
      std::uint64_t zz = 0;
      if (!bits.get_eg(k_len, len_minus_1) || !bits.get_eg(k_val, zz)) {
        return Status(bit_error(std::string("truncated or overlong ") + what + " run"));
      }
      if (len_minus_1 >= values_end - i) return Status(bit_error(std::string(what) + " run passes the last value edit"));
      const std::size_t end_i = i + static_cast<std::size_t>(len_minus_1) + 1;
      if (std::optional<std::string> bad = apply(i, end_i, unzigzag(zz))) return Status(bit_error(*bad));
      i = end_i;
    }
    if (i != values_end) return Status(bit_error(std::string(what) + " runs cover fewer edits than the batch holds"));
    return Ok{};
  };
  if (values_end > values_begin) {
    std::int64_t prev_obj = 0;
    Status st = read_runs("object-id", [&](std::size_t from, std::size_t to, std::int64_t delta) -> std::optional<std::string> {
      // Check the delta before adding so a hostile delta cannot overflow the sum.
      if (delta > (std::int64_t{1} << 33) || delta < -(std::int64_t{1} << 33)) return "object id delta outside 33 bits";
      const std::int64_t obj = prev_obj + delta;
      if (obj < std::numeric_limits<std::int32_t>::min() || obj > std::numeric_limits<std::int32_t>::max()) {
        return "object id outside 32 bits";
      }
      prev_obj = obj;
      for (std::size_t i = from; i < to; ++i) batch.edits[i].value.object = ObjectId{static_cast<std::int32_t>(obj)};
      return std::nullopt;
    });
    if (!st) return st.error();
    std::uint64_t mode = 0;
    if (!bits.get(1, mode)) return bit_error("truncated support column");
    if (mode == 0) {
      for (std::size_t i = values_begin; i < values_end; ++i) {
        if (!bits.get(kSupportCodeBits, v)) return bit_error("truncated support column");
        batch.edits[i].value.support = codec_detail::dequantize_support(static_cast<std::uint8_t>(v));
      }
    } else {
      std::int64_t prev_code = 0;
      st = read_runs("support", [&](std::size_t from, std::size_t to, std::int64_t delta) -> std::optional<std::string> {
        if (delta > std::int64_t{kMaxSupportCode} || delta < -std::int64_t{kMaxSupportCode}) return "support code delta out of range";
        const std::int64_t code = prev_code + delta;
        if (code < 0 || code > std::int64_t{kMaxSupportCode}) return "support code out of range";
        prev_code = code;
        const std::uint32_t s = codec_detail::dequantize_support(static_cast<std::uint8_t>(code));
        for (std::size_t i = from; i < to; ++i) batch.edits[i].value.support = s;
        return std::nullopt;
      });
      if (!st) return st.error();
    }
  }
  if (!bits.align()) return bit_error("non-zero padding after the bit columns");
  if (!rd.bytes(bits.byte_offset(), head)) return decode_error(rd.offset(), "truncated bit columns");
  const std::uint8_t* records = nullptr;
  if (!rd.bytes((values_end - values_begin) * rec, records)) {
    return decode_error(rd.offset(), "truncated records (" + std::to_string(values_end - values_begin) + " x " +
                                         std::to_string(rec) + " bytes expected)");
  }
  for (std::size_t i = values_begin; i < values_end; ++i) {
    Gaussian& g = batch.edits[i].value;
    codec_detail::read_record(records + (i - values_begin) * rec, params, g);
    g.id = batch.edits[i].id;
  }
  if (rd.remaining() != 0) {
    return decode_error(rd.offset(), std::to_string(rd.remaining()) + " trailing bytes after the records");
  }
  return batch;
}

std::vector<std::uint8_t> encode_edit_batch(const EditBatch& batch, const CodecParams& params, CodecStats* stats,
                                            std::span<const std::uint8_t> sent_records) {
  return compress_payload(encode_edit_batch_raw(batch, params, stats, sent_records), stats);
}

Expected<EditBatch> decode_edit_batch(std::span<const std::uint8_t> bytes, const CodecParams& params) {
  const unsigned long long declared = ZSTD_getFrameContentSize(bytes.data(), bytes.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR) return Error{"edit batch: not a zstd frame"};
  if (declared == ZSTD_CONTENTSIZE_UNKNOWN) return Error{"edit batch: zstd frame without a content size"};
  if (declared > kMaxPayloadBytes) {
    return Error{"edit batch: zstd frame declares " + std::to_string(declared) + " bytes, above the limit"};
  }
  const std::size_t frame = ZSTD_findFrameCompressedSize(bytes.data(), bytes.size());
  if (ZSTD_isError(frame)) return Error{std::string("edit batch: bad zstd frame: ") + ZSTD_getErrorName(frame)};
  if (frame != bytes.size()) {
    return Error{"edit batch: " + std::to_string(bytes.size() - frame) + " bytes after the zstd frame"};
  }
  std::vector<std::uint8_t> raw(static_cast<std::size_t>(declared));
  const std::size_t n = ZSTD_decompress(raw.data(), raw.size(), bytes.data(), bytes.size());
  if (ZSTD_isError(n)) return Error{std::string("edit batch: zstd: ") + ZSTD_getErrorName(n)};
  if (n != raw.size()) return Error{"edit batch: zstd frame shorter than its declared size"};
  return decode_edit_batch_raw(raw, params);
}

}  // namespace gauss
