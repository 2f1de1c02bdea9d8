#pragma once
// Per-message pieces the frame encoder dispatches to (private to engine/src/wire).
// check(): the schema's semantic rules, used by the encoder (never write what the
// decoder refuses) and by the decoder after the structural read.
// write(): the body, fields in schema order; assumes check() passed.
#include "byte_io.h"
#include "gauss/engine/messages.h"

namespace gauss::wire::detail {

Status check(const msg::Hello& m);
Status check(const msg::Welcome& m);
Status check(const msg::Refuse& m);
Status check(const msg::SceneInfo& m);
Status check(const msg::EditBatchMsg& m);
Status check(const msg::SurfacePatch& m);
Status check(const msg::ObjectTableUpdate& m);
Status check(const msg::HeadPose& m);
Status check(const msg::Query& m);
Status check(const msg::QueryReply& m);
Status check(const msg::Ack& m);
Status check(const msg::ClientStats& m);
Status check(const msg::Challenge& m);
Status check(const msg::AuthProof& m);
inline Status check(const msg::AuthConfirm&) { return Ok{}; }  // any 32 bytes

void write(const msg::Hello& m, Writer& w);
void write(const msg::Welcome& m, Writer& w);
void write(const msg::Refuse& m, Writer& w);
void write(const msg::SceneInfo& m, Writer& w);
void write(const msg::EditBatchMsg& m, Writer& w);
// The surface patch compresses its mesh, which can fail (zstd error): hence Status.
Status write(const msg::SurfacePatch& m, Writer& w);
void write(const msg::ObjectTableUpdate& m, Writer& w);
void write(const msg::HeadPose& m, Writer& w);
void write(const msg::Query& m, Writer& w);
void write(const msg::QueryReply& m, Writer& w);
void write(const msg::Ack& m, Writer& w);
void write(const msg::ClientStats& m, Writer& w);
void write(const msg::Challenge& m, Writer& w);
void write(const msg::AuthProof& m, Writer& w);
void write(const msg::AuthConfirm& m, Writer& w);

// An id list on the wire: u32 count, then each ObjectId as i32 (QueryReply targets,
// ObjectTableUpdate removed). read_ids bounds the count by `max` and by the bytes left.
inline void write_ids(const std::vector<ObjectId>& ids, Writer& w) {
  w.u32(static_cast<std::uint32_t>(ids.size()));
  for (ObjectId id : ids) w.i32(to_underlying(id));
}
inline bool read_ids(Reader& r, const char* field, std::size_t max, std::vector<ObjectId>& out) {
  std::uint32_t n = 0;
  if (!r.count(field, n, max, 4)) return false;
  out.resize(n);
  for (auto& id : out) {
    std::int32_t v = 0;
    r.i32(field, v);
    id = ObjectId{v};
  }
  return r.ok();
}

// Runs check() on a structurally decoded message: the decoder's last step.
template <class T>
Expected<T> checked(T m) {
  if (auto s = check(m); !s) return s.error();
  return m;
}

}  // namespace gauss::wire::detail
