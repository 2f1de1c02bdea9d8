// Hello / Welcome / Refuse: frozen forever (see messages.h), so any protocol
// version can read them and refuse cleanly.
#include <algorithm>
#include <array>
#include <string>

#include "codecs.h"
#include "gauss/engine/wire.h"

namespace gauss::wire {
namespace detail {

namespace {

// Hello asks for a capacity, Welcome confirms one: the same bound either way.
Status check_slot_capacity(const char* message, std::uint32_t capacity) {
  if (capacity < 1 || capacity > gauss::kMaxSlotCapacity)
    return field_error(message, "slot_capacity",
                       std::to_string(capacity) + " outside [1, " + std::to_string(gauss::kMaxSlotCapacity) + "]");
  return Ok{};
}

}  // namespace

Status check(const msg::Hello& m) {
  if (auto s = check_slot_capacity("Hello", m.slot_capacity); !s) return s;
  if (m.access_token.size() > msg::kMaxTokenBytes)
    return field_error("Hello", "access_token", "longer than " + std::to_string(msg::kMaxTokenBytes) + " bytes");
  if (m.client_name.size() > msg::kMaxLabelBytes)
    return field_error("Hello", "client_name", "longer than " + std::to_string(msg::kMaxLabelBytes) + " bytes");
  return Ok{};
}

Status check(const msg::Welcome& m) { return check_slot_capacity("Welcome", m.slot_capacity); }

Status check(const msg::Refuse& m) {
  const auto r = static_cast<std::uint8_t>(m.reason);
  if (r < 1 || r > msg::kLastRefuseReason) return field_error("Refuse", "reason", "unknown value " + std::to_string(r));
  if (m.detail.size() > msg::kMaxReasonBytes)
    return field_error("Refuse", "detail", "longer than " + std::to_string(msg::kMaxReasonBytes) + " bytes");
  return Ok{};
}

void write(const msg::Hello& m, Writer& w) {
  w.u32(m.protocol_version);
  w.u32(m.slot_capacity);
  w.str(m.access_token);
  w.str(m.client_name);
}

void write(const msg::Welcome& m, Writer& w) {
  w.u32(m.protocol_version);
  w.u64(m.session_id);
  w.u32(m.client_id);
  w.u32(m.slot_capacity);
}

void write(const msg::Refuse& m, Writer& w) {
  w.u8(static_cast<std::uint8_t>(m.reason));
  w.u32(m.host_protocol_version);
  w.str(m.detail);
}

void write(const msg::Challenge& m, Writer& w) {
  w.raw(m.nonce);
  w.u8(m.flags);
}
void write(const msg::AuthProof& m, Writer& w) { w.raw(m.mac); }

}  // namespace detail

Expected<msg::Hello> decode_hello(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Hello");
  msg::Hello m;
  r.u32("protocol_version", m.protocol_version);
  r.u32("slot_capacity", m.slot_capacity);
  r.str("access_token", m.access_token, msg::kMaxTokenBytes);
  r.str("client_name", m.client_name, msg::kMaxLabelBytes);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::Welcome> decode_welcome(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Welcome");
  msg::Welcome m;
  r.u32("protocol_version", m.protocol_version);
  r.u64("session_id", m.session_id);
  r.u32("client_id", m.client_id);
  r.u32("slot_capacity", m.slot_capacity);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::Refuse> decode_refuse(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Refuse");
  msg::Refuse m;
  std::uint8_t reason = 0;
  r.u8("reason", reason);
  m.reason = static_cast<msg::RefuseReason>(reason);
  r.u32("host_protocol_version", m.host_protocol_version);
  r.str("detail", m.detail, msg::kMaxReasonBytes);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

namespace {

// A fixed-size byte field: exactly N bytes, nothing after them.
template <std::size_t N>
bool read_fixed(detail::Reader& r, const char* field, std::array<std::uint8_t, N>& out) {
  std::span<const std::uint8_t> v;
  if (!r.view(field, N, v)) return false;
  std::copy(v.begin(), v.end(), out.begin());
  return true;
}

}  // namespace

Expected<msg::Challenge> decode_challenge(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Challenge");
  msg::Challenge m;
  read_fixed(r, "nonce", m.nonce);
  r.u8("flags", m.flags);
  if (r.ok() && (m.flags & ~msg::kChallengeKnownFlags) != 0)
    r.fail_at("flags", msg::kAuthNonceBytes, "unknown flag bits " + std::to_string(m.flags & ~msg::kChallengeKnownFlags));
  if (!r.finish()) return r.error();
  return m;
}

Expected<msg::AuthProof> decode_auth_proof(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "AuthProof");
  msg::AuthProof m;
  read_fixed(r, "mac", m.mac);
  if (!r.finish()) return r.error();
  return m;
}

}  // namespace gauss::wire
