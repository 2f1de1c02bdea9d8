// Model-stream messages: SceneInfo, EditBatch, ObjectTableUpdate (and the
// ObjectInfo record they share).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "codecs.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/wire.h"

namespace gauss::wire {
namespace detail {
namespace {

// id, label length, centroid, extent_min, extent_max, quality, member_count
constexpr std::size_t kObjectInfoMinBytes = 4 + 4 + 3 * 12 + 4 + 4;

// Sorts `ids` and returns the first one that appears twice, or nullptr.
const std::int32_t* first_duplicate(std::vector<std::int32_t>& ids) {
  std::sort(ids.begin(), ids.end());
  const auto dup = std::adjacent_find(ids.begin(), ids.end());
  return dup == ids.end() ? nullptr : &*dup;
}

Status check_object(const char* message, const std::string& where, const msg::ObjectInfo& o) {
  if (to_underlying(o.id) < 0) return field_error(message, where + ".id", "negative object id " + std::to_string(to_underlying(o.id)));
  if (o.label.size() > msg::kMaxLabelBytes)
    return field_error(message, where + ".label", "longer than " + std::to_string(msg::kMaxLabelBytes) + " bytes");
  if (!finite3(o.centroid) || !finite3(o.extent_min) || !finite3(o.extent_max))
    return field_error(message, where, "non-finite centroid or extent");
  if (o.extent_min.x > o.extent_max.x || o.extent_min.y > o.extent_max.y || o.extent_min.z > o.extent_max.z)
    return field_error(message, where + ".extent_min", "greater than extent_max");
  if (!(o.quality >= 0.0f && o.quality <= 1.0f))
    return field_error(message, where + ".quality", "outside [0, 1]");
  return Ok{};
}

Status check_objects(const char* message, const char* field, const std::vector<msg::ObjectInfo>& objects) {
  if (objects.size() > msg::kMaxObjects)
    return field_error(message, field, std::to_string(objects.size()) + " objects exceed " + std::to_string(msg::kMaxObjects));
  std::vector<std::int32_t> ids;
  ids.reserve(objects.size());
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (auto s = check_object(message, std::string(field) + "[" + std::to_string(i) + "]", objects[i]); !s) return s;
    ids.push_back(to_underlying(objects[i].id));
  }
  if (const auto* dup = first_duplicate(ids))
    return field_error(message, field, "object id " + std::to_string(*dup) + " appears twice");
  return Ok{};
}

void write_object(const msg::ObjectInfo& o, Writer& w) {
  w.i32(to_underlying(o.id));
  w.str(o.label);
  w.vec3(o.centroid);
  w.vec3(o.extent_min);
  w.vec3(o.extent_max);
  w.f32(o.quality);
  w.u32(o.member_count);
}

bool read_objects(Reader& r, const char* field, std::vector<msg::ObjectInfo>& out) {
  std::uint32_t n = 0;
  if (!r.count(field, n, msg::kMaxObjects, kObjectInfoMinBytes)) return false;
  out.resize(n);
  for (auto& o : out) {
    std::int32_t id = 0;
    r.i32(field, id);
    o.id = ObjectId{id};
    r.str(field, o.label, msg::kMaxLabelBytes);
    r.vec3(field, o.centroid);
    r.vec3(field, o.extent_min);
    r.vec3(field, o.extent_max);
    r.f32(field, o.quality);
    r.u32(field, o.member_count);
    if (!r.ok()) return false;
  }
  return true;
}

}  // namespace

Status check(const msg::SceneInfo& m) {
  if (auto s = validate_codec_params(m.codec); !s) return field_error("SceneInfo", "codec", s.message());
  if (!finite3(m.bounds_min) || !finite3(m.bounds_max)) return field_error("SceneInfo", "bounds", "not finite");
  if (m.bounds_min.x > m.bounds_max.x || m.bounds_min.y > m.bounds_max.y || m.bounds_min.z > m.bounds_max.z)
    return field_error("SceneInfo", "bounds_min", "greater than bounds_max");
  const msg::SceneView& v = m.view;
  if (!finite3(v.up) || std::abs(glm::length(v.up) - 1.0f) > 1e-3f)
    return field_error("SceneInfo", "view.up", "not a unit vector");
  if (!finite3(v.subject_min) || !finite3(v.subject_max)) return field_error("SceneInfo", "view.subject", "not finite");
  if (v.subject_min.x > v.subject_max.x || v.subject_min.y > v.subject_max.y || v.subject_min.z > v.subject_max.z)
    return field_error("SceneInfo", "view.subject_min", "greater than view.subject_max");
  if ((v.flags & ~msg::kViewKnownFlags) != 0)
    return field_error("SceneInfo", "view.flags", "unknown bits " + std::to_string(v.flags & ~msg::kViewKnownFlags));
  if (!finite3(v.seen_from)) return field_error("SceneInfo", "view.seen_from", "not finite");
  return check_objects("SceneInfo", "objects", m.objects);
}

Status check(const msg::EditBatchMsg& m) {
  if (m.edit_count > msg::kMaxEditsPerBatch)
    return field_error("EditBatch", "edit_count", std::to_string(m.edit_count) + " exceeds " + std::to_string(msg::kMaxEditsPerBatch));
  if ((m.flags & ~msg::kBatchKnownFlags) != 0)
    return field_error("EditBatch", "flags", "unknown bits " + std::to_string(m.flags & ~msg::kBatchKnownFlags));
  if (m.payload.size() > msg::kMaxMessageBytes - kHeaderBytes)
    return field_error("EditBatch", "payload", std::to_string(m.payload.size()) + " bytes exceed the message limit");
  return Ok{};
}

Status check(const msg::ObjectTableUpdate& m) {
  if (auto s = check_objects("ObjectTableUpdate", "upserts", m.upserts); !s) return s;
  if (m.removed.size() > msg::kMaxObjects)
    return field_error("ObjectTableUpdate", "removed", std::to_string(m.removed.size()) + " ids exceed " + std::to_string(msg::kMaxObjects));
  std::vector<std::int32_t> removed;
  removed.reserve(m.removed.size());
  for (ObjectId id : m.removed) {
    if (to_underlying(id) < 0) return field_error("ObjectTableUpdate", "removed", "negative object id " + std::to_string(to_underlying(id)));
    removed.push_back(to_underlying(id));
  }
  if (const auto* dup = first_duplicate(removed))  // leaves `removed` sorted
    return field_error("ObjectTableUpdate", "removed", "object id " + std::to_string(*dup) + " appears twice");
  for (const auto& o : m.upserts)
    if (std::binary_search(removed.begin(), removed.end(), to_underlying(o.id)))
      return field_error("ObjectTableUpdate", "removed", "object id " + std::to_string(to_underlying(o.id)) + " is also upserted");
  return Ok{};
}

void write(const msg::SceneInfo& m, Writer& w) {
  w.u64(to_underlying(m.epoch));
  w.vec3(m.bounds_min);
  w.vec3(m.bounds_max);
  w.vec3(m.codec.box.min);
  w.vec3(m.codec.box.max);
  w.u8(static_cast<std::uint8_t>(m.codec.sh_degree));
  w.f32(m.codec.log_scale_min);
  w.f32(m.codec.log_scale_max);
  w.f32(m.codec.dc_min);
  w.f32(m.codec.dc_max);
  w.f32(m.codec.sh_rest_abs_max);
  w.u64(m.total_gaussians);
  w.u32(static_cast<std::uint32_t>(m.objects.size()));
  for (const auto& o : m.objects) write_object(o, w);
  w.vec3(m.view.up);
  w.vec3(m.view.subject_min);
  w.vec3(m.view.subject_max);
  w.u8(m.view.flags);
  w.vec3(m.view.seen_from);
}

void write(const msg::EditBatchMsg& m, Writer& w) {
  w.u64(to_underlying(m.epoch));
  w.u64(m.batch_id);
  w.u32(m.edit_count);
  w.u8(m.flags);
  w.u64(m.host_time_us);
  w.bytes(m.payload);
}

void write(const msg::ObjectTableUpdate& m, Writer& w) {
  w.u64(to_underlying(m.epoch));
  w.u32(static_cast<std::uint32_t>(m.upserts.size()));
  for (const auto& o : m.upserts) write_object(o, w);
  write_ids(m.removed, w);
}

}  // namespace detail

Expected<msg::SceneInfo> decode_scene_info(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "SceneInfo");
  msg::SceneInfo m;
  std::uint64_t epoch = 0;
  r.u64("epoch", epoch);
  m.epoch = Epoch{epoch};
  r.vec3("bounds_min", m.bounds_min);
  r.vec3("bounds_max", m.bounds_max);
  r.vec3("codec.box.min", m.codec.box.min);
  r.vec3("codec.box.max", m.codec.box.max);
  std::uint8_t degree = 0;
  r.u8("codec.sh_degree", degree);
  m.codec.sh_degree = degree;
  r.f32("codec.log_scale_min", m.codec.log_scale_min);
  r.f32("codec.log_scale_max", m.codec.log_scale_max);
  r.f32("codec.dc_min", m.codec.dc_min);
  r.f32("codec.dc_max", m.codec.dc_max);
  r.f32("codec.sh_rest_abs_max", m.codec.sh_rest_abs_max);
  r.u64("total_gaussians", m.total_gaussians);
  if (r.ok()) detail::read_objects(r, "objects", m.objects);
  r.vec3("view.up", m.view.up);
  r.vec3("view.subject_min", m.view.subject_min);
  r.vec3("view.subject_max", m.view.subject_max);
  r.u8("view.flags", m.view.flags);
  r.vec3("view.seen_from", m.view.seen_from);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::EditBatchMsg> decode_edit_batch_msg(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "EditBatch");
  msg::EditBatchMsg m;
  std::uint64_t epoch = 0;
  r.u64("epoch", epoch);
  m.epoch = Epoch{epoch};
  r.u64("batch_id", m.batch_id);
  r.u32("edit_count", m.edit_count);
  r.u8("flags", m.flags);
  r.u64("host_time_us", m.host_time_us);
  r.bytes("payload", m.payload, msg::kMaxMessageBytes - kHeaderBytes);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::ObjectTableUpdate> decode_object_table_update(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "ObjectTableUpdate");
  msg::ObjectTableUpdate m;
  std::uint64_t epoch = 0;
  r.u64("epoch", epoch);
  m.epoch = Epoch{epoch};
  if (r.ok()) detail::read_objects(r, "upserts", m.upserts);
  detail::read_ids(r, "removed", msg::kMaxObjects, m.removed);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

}  // namespace gauss::wire

namespace gauss::msg {

bool operator==(const SceneInfo& a, const SceneInfo& b) {
  const auto& p = a.codec;
  const auto& q = b.codec;
  return a.epoch == b.epoch && a.bounds_min == b.bounds_min && a.bounds_max == b.bounds_max &&
         p.box.min == q.box.min && p.box.max == q.box.max && p.sh_degree == q.sh_degree &&
         p.log_scale_min == q.log_scale_min && p.log_scale_max == q.log_scale_max && p.dc_min == q.dc_min &&
         p.dc_max == q.dc_max && p.sh_rest_abs_max == q.sh_rest_abs_max && a.total_gaussians == b.total_gaussians &&
         a.objects == b.objects && a.view == b.view;
}

}  // namespace gauss::msg
