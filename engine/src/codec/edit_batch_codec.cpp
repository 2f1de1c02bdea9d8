// Edit batches on the wire: columnar payload (ids, object ids, support, records) and
// its zstd frame. The layout is documented in gauss/engine/codec.h.
#include <algorithm>
#include <cstring>
#include <limits>
#include <string>

#include <zstd.h>

#include "codec/record_bits.h"
#include "gauss/engine/codec.h"

namespace gauss {
namespace {

using codec_detail::put_varint;
using codec_detail::unzigzag;
using codec_detail::zigzag;

constexpr std::uint8_t kMagic[4] = {'G', 'A', 'E', 'B'};

// Edits grouped in wire order: removes, replaces, updates, inserts, each by id.
struct Grouped {
  std::vector<const Edit*> group[4];
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

void put_sorted_ids(std::vector<std::uint8_t>& out, const std::vector<const Edit*>& edits) {
  std::uint64_t prev = 0;
  for (const Edit* e : edits) {
    const std::uint64_t id = to_underlying(e->id);
    put_varint(out, id - prev);
    prev = id;
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

std::vector<std::uint8_t> encode_edit_batch_raw(const EditBatch& batch, const CodecParams& params,
                                                CodecStats* stats) {
  Grouped g;
  for (const Edit& e : batch.edits) g.group[wire_group(e.kind)].push_back(&e);
  for (auto& grp : g.group) {
    std::sort(grp.begin(), grp.end(),
              [](const Edit* a, const Edit* b) { return to_underlying(a->id) < to_underlying(b->id); });
  }
  const int degree = std::clamp(params.sh_degree, 0, kMaxShDegree);
  const std::size_t rec = record_bytes(degree);
  const std::size_t n_values = g.group[1].size() + g.group[2].size() + g.group[3].size();

  std::vector<std::uint8_t> out;
  out.reserve(32 + g.group[0].size() * 3 + g.group[1].size() * 3 + n_values * (rec + 6));
  for (std::uint8_t m : kMagic) out.push_back(m);
  out.push_back(static_cast<std::uint8_t>(kCodecVersion));
  out.push_back(static_cast<std::uint8_t>(degree));
  put_varint(out, to_underlying(batch.epoch));
  for (const auto& grp : g.group) put_varint(out, grp.size());

  put_sorted_ids(out, g.group[0]);
  put_sorted_ids(out, g.group[1]);
  std::uint64_t prev_leaving = 0;
  for (const Edit* e : g.group[1]) {
    const std::uint64_t id = to_underlying(e->leaving);
    put_varint(out, zigzag(static_cast<std::int64_t>(id - prev_leaving)));  // wraps on purpose: exact inverse
    prev_leaving = id;
  }
  put_sorted_ids(out, g.group[2]);
  put_sorted_ids(out, g.group[3]);

  std::int64_t prev_obj = 0;
  for (int k = 1; k < 4; ++k) {
    for (const Edit* e : g.group[k]) {
      const std::int64_t obj = to_underlying(e->value.object);
      put_varint(out, zigzag(obj - prev_obj));
      prev_obj = obj;
    }
  }
  for (int k = 1; k < 4; ++k) {
    for (const Edit* e : g.group[k]) out.push_back(codec_detail::support_code(e->value.support, stats));
  }
  const std::size_t rec_start = out.size();
  out.resize(rec_start + n_values * rec);
  std::uint8_t* r = out.data() + rec_start;
  for (int k = 1; k < 4; ++k) {
    for (const Edit* e : g.group[k]) {
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
    // Every edit costs at least one payload byte, so a count beyond the payload is a
    // lie: reject it before reserving anything.
    if (c > payload.size()) return decode_error(at, "edit count " + std::to_string(c) + " exceeds payload size");
  }
  const std::size_t rec = record_bytes(params.sh_degree);
  const std::uint64_t n_values = n[1] + n[2] + n[3];
  if (n[0] + n_values > kMaxBatchEdits) {
    return decode_error(rd.offset(), std::to_string(n[0] + n_values) + " edits exceed the limit of " +
                                         std::to_string(kMaxBatchEdits) + " per batch");
  }
  // Each value edit needs >= 1 id byte, 1 object byte, 1 support byte and its record.
  if (n_values * (rec + 3) + n[0] + n[1] > rd.remaining()) {
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
  auto read_ids = [&](int k) -> Status {
    std::uint64_t prev = 0;
    for (std::uint64_t i = 0; i < n[k]; ++i) {
      const std::size_t at = rd.offset();
      std::uint64_t d = 0;
      if (!rd.varint(d)) return Status(decode_error(at, "truncated or overlong id varint"));
      if (i > 0 && d == 0) return Status(decode_error(at, "id repeated within a group"));
      if (d > std::numeric_limits<std::uint64_t>::max() - prev) {
        return Status(decode_error(at, "id delta overflows 64 bits"));
      }
      prev += d;
      Edit& e = batch.edits[first[k] + static_cast<std::size_t>(i)];
      e.kind = kinds[k];
      e.id = GaussianId{prev};
    }
    return Ok{};
  };
  if (Status st = read_ids(0); !st) return st.error();
  if (Status st = read_ids(1); !st) return st.error();
  std::uint64_t prev_leaving = 0;
  for (std::uint64_t i = 0; i < n[1]; ++i) {
    const std::size_t at = rd.offset();
    if (!rd.varint(v)) return decode_error(at, "truncated or overlong leaving-id varint");
    prev_leaving += static_cast<std::uint64_t>(unzigzag(v));
    batch.edits[first[1] + static_cast<std::size_t>(i)].leaving = GaussianId{prev_leaving};
  }
  if (Status st = read_ids(2); !st) return st.error();
  if (Status st = read_ids(3); !st) return st.error();

  const std::size_t values_begin = first[1];
  const std::size_t values_end = batch.edits.size();
  std::int64_t prev_obj = 0;
  for (std::size_t i = values_begin; i < values_end; ++i) {
    const std::size_t at = rd.offset();
    if (!rd.varint(v)) return decode_error(at, "truncated or overlong object-id varint");
    // Check the delta before adding so a hostile delta cannot overflow the sum.
    const std::int64_t delta = unzigzag(v);
    if (delta > (std::int64_t{1} << 33) || delta < -(std::int64_t{1} << 33)) {
      return decode_error(at, "object id delta outside 33 bits");
    }
    const std::int64_t obj = prev_obj + delta;
    if (obj < std::numeric_limits<std::int32_t>::min() || obj > std::numeric_limits<std::int32_t>::max()) {
      return decode_error(at, "object id outside 32 bits");
    }
    prev_obj = obj;
    batch.edits[i].value.object = ObjectId{static_cast<std::int32_t>(obj)};
  }
  const std::uint8_t* support = nullptr;
  if (!rd.bytes(values_end - values_begin, support)) return decode_error(rd.offset(), "truncated support column");
  for (std::size_t i = values_begin; i < values_end; ++i) {
    batch.edits[i].value.support = codec_detail::dequantize_support(support[i - values_begin]);
  }
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

std::vector<std::uint8_t> encode_edit_batch(const EditBatch& batch, const CodecParams& params, CodecStats* stats) {
  const std::vector<std::uint8_t> raw = encode_edit_batch_raw(batch, params, stats);
  std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), kZstdLevel);
  // Compressing into a ZSTD_compressBound-sized buffer cannot fail except on allocation
  // failure inside zstd; an empty result then makes the receiver reject the batch.
  out.resize(ZSTD_isError(n) ? 0 : n);
  if (stats) stats->compressed_bytes += out.size();
  return out;
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
