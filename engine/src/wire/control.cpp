// Control-channel messages: HeadPose, Query, QueryReply, Ack, ClientStats.
#include <cmath>
#include <string>

#include "codecs.h"
#include "gauss/engine/wire.h"

namespace gauss::wire {
namespace detail {

Status check(const msg::HeadPose& m) {
  if (!finite3(m.position)) return field_error("HeadPose", "position", "not finite");
  if (!finite4(m.rotation)) return field_error("HeadPose", "rotation", "not finite");
  const double len = std::sqrt(double(m.rotation.x) * m.rotation.x + double(m.rotation.y) * m.rotation.y +
                               double(m.rotation.z) * m.rotation.z + double(m.rotation.w) * m.rotation.w);
  // Senders normalise; a quaternion far from unit length is a corrupt pose, not a rotation.
  if (std::abs(len - 1.0) > 1e-3) return field_error("HeadPose", "rotation", "length " + std::to_string(len) + " is not 1");
  // tan(half FOV) of 100 is a 179-degree view: anything wider is not a head-mounted display.
  if (!(m.tan_half_fov_x > 0.0f && m.tan_half_fov_x <= 100.0f))
    return field_error("HeadPose", "tan_half_fov_x", "outside (0, 100]");
  if (!(m.tan_half_fov_y > 0.0f && m.tan_half_fov_y <= 100.0f))
    return field_error("HeadPose", "tan_half_fov_y", "outside (0, 100]");
  return Ok{};
}

Status check(const msg::Query& m) {
  const auto kind = static_cast<std::uint8_t>(m.kind);
  if (kind > msg::kLastQueryKind) return field_error("Query", "kind", "unknown value " + std::to_string(kind));
  if (!(m.rho == msg::kHostDefaultRho || (m.rho >= 0.0f && m.rho <= 1.0f)))
    return field_error("Query", "rho", "neither in [0, 1] nor -1 (the host's default)");
  if (m.text.size() > msg::kMaxQueryTextBytes)
    return field_error("Query", "text", "longer than " + std::to_string(msg::kMaxQueryTextBytes) + " bytes");
  switch (m.kind) {
    case msg::QueryKind::Clear:
      if (!m.text.empty() || m.instance != kNoObject || m.rho != 0.0f)
        return field_error("Query", "kind", "Clear carries no text, instance or rho");
      break;
    case msg::QueryKind::ClassText:
      if (m.text.empty()) return field_error("Query", "text", "empty class text");
      if (m.instance != kNoObject) return field_error("Query", "instance", "set on a class-text query");
      break;
    case msg::QueryKind::Instance:
      if (to_underlying(m.instance) < 0) return field_error("Query", "instance", "negative object id");
      if (!m.text.empty()) return field_error("Query", "text", "set on an instance query");
      break;
  }
  return Ok{};
}

Status check(const msg::QueryReply& m) {
  const auto status = static_cast<std::uint8_t>(m.status);
  if (status > msg::kLastQueryStatus) return field_error("QueryReply", "status", "unknown value " + std::to_string(status));
  if (m.targets.size() > msg::kMaxQueryTargets)
    return field_error("QueryReply", "targets", std::to_string(m.targets.size()) + " exceed " + std::to_string(msg::kMaxQueryTargets));
  for (ObjectId id : m.targets)
    if (to_underlying(id) < 0) return field_error("QueryReply", "targets", "negative object id");
  if (m.reason.size() > msg::kMaxReasonBytes)
    return field_error("QueryReply", "reason", "longer than " + std::to_string(msg::kMaxReasonBytes) + " bytes");
  return Ok{};
}

Status check(const msg::Ack& m) {
  if (to_underlying(m.published_epoch) > to_underlying(m.received_epoch))
    return field_error("Ack", "published_epoch", "newer than received_epoch");
  return Ok{};
}

Status check(const msg::ClientStats& m) {
  if (!std::isfinite(m.frame_ms) || m.frame_ms < 0.0f) return field_error("ClientStats", "frame_ms", "negative or not finite");
  if (!std::isfinite(m.slack_ms)) return field_error("ClientStats", "slack_ms", "not finite");
  if (m.capacity > gauss::kMaxSlotCapacity) return field_error("ClientStats", "capacity", "exceeds the slot limit");
  if (m.resident > m.capacity) return field_error("ClientStats", "resident", "exceeds capacity");
  return Ok{};
}

void write(const msg::HeadPose& m, Writer& w) {
  w.u32(m.sequence);
  w.u64(m.client_time_us);
  w.vec3(m.position);
  w.vec4(m.rotation);
  w.f32(m.tan_half_fov_x);
  w.f32(m.tan_half_fov_y);
}

void write(const msg::Query& m, Writer& w) {
  w.u32(m.query_id);
  w.u8(static_cast<std::uint8_t>(m.kind));
  w.str(m.text);
  w.i32(to_underlying(m.instance));
  w.f32(m.rho);
}

void write(const msg::QueryReply& m, Writer& w) {
  w.u32(m.query_id);
  w.u8(static_cast<std::uint8_t>(m.status));
  w.u64(to_underlying(m.epoch));
  write_ids(m.targets, w);
  w.u64(m.target_gaussians);
  w.str(m.reason);
}

void write(const msg::Ack& m, Writer& w) {
  w.u64(m.last_batch_id);
  w.u64(to_underlying(m.received_epoch));
  w.u64(to_underlying(m.published_epoch));
}

void write(const msg::ClientStats& m, Writer& w) {
  w.u64(m.client_time_us);
  w.u64(m.frames);
  w.u32(m.resident);
  w.u32(m.desired);
  w.u32(m.pending_edits);
  w.u32(m.capacity);
  w.f32(m.frame_ms);
  w.f32(m.slack_ms);
  w.u32(m.rejected_messages);
}

}  // namespace detail

Expected<msg::HeadPose> decode_head_pose(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "HeadPose");
  msg::HeadPose m;
  r.u32("sequence", m.sequence);
  r.u64("client_time_us", m.client_time_us);
  r.vec3("position", m.position);
  r.vec4("rotation", m.rotation);
  r.f32("tan_half_fov_x", m.tan_half_fov_x);
  r.f32("tan_half_fov_y", m.tan_half_fov_y);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::Query> decode_query(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Query");
  msg::Query m;
  std::uint8_t kind = 0;
  std::int32_t instance = 0;
  r.u32("query_id", m.query_id);
  r.u8("kind", kind);
  m.kind = static_cast<msg::QueryKind>(kind);
  r.str("text", m.text, msg::kMaxQueryTextBytes);
  r.i32("instance", instance);
  m.instance = ObjectId{instance};
  r.f32("rho", m.rho);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::QueryReply> decode_query_reply(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "QueryReply");
  msg::QueryReply m;
  std::uint8_t status = 0;
  std::uint64_t epoch = 0;
  r.u32("query_id", m.query_id);
  r.u8("status", status);
  m.status = static_cast<msg::QueryStatus>(status);
  r.u64("epoch", epoch);
  m.epoch = Epoch{epoch};
  detail::read_ids(r, "targets", msg::kMaxQueryTargets, m.targets);
  r.u64("target_gaussians", m.target_gaussians);
  r.str("reason", m.reason, msg::kMaxReasonBytes);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::Ack> decode_ack(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Ack");
  msg::Ack m;
  std::uint64_t received = 0, published = 0;
  r.u64("last_batch_id", m.last_batch_id);
  r.u64("received_epoch", received);
  r.u64("published_epoch", published);
  m.received_epoch = Epoch{received};
  m.published_epoch = Epoch{published};
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::ClientStats> decode_client_stats(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "ClientStats");
  msg::ClientStats m;
  r.u64("client_time_us", m.client_time_us);
  r.u64("frames", m.frames);
  r.u32("resident", m.resident);
  r.u32("desired", m.desired);
  r.u32("pending_edits", m.pending_edits);
  r.u32("capacity", m.capacity);
  r.f32("frame_ms", m.frame_ms);
  r.f32("slack_ms", m.slack_ms);
  r.u32("rejected_messages", m.rejected_messages);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

}  // namespace gauss::wire
