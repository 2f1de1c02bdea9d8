// The handshake's messages. Hello / Welcome / Refuse: frozen forever (see messages.h), so
// any protocol version can read them and refuse cleanly. Challenge / AuthProof /
// AuthConfirm: the CPace exchange (messages.h; gauss/net/auth.h does the cryptography).
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

namespace {

// The CPace message's framing (messages.h, kPakeMessageBytes): the point's length byte
// and the empty associated data's. The point itself is judged where it is used (net/).
std::string pake_framing_error(const msg::PakeMessage& pake) {
  if (pake.front() != msg::kPakePointBytes)
    return "the point's length byte is " + std::to_string(pake.front()) + ", must be " +
           std::to_string(msg::kPakePointBytes);
  if (pake.back() != 0)
    return "the associated data's length byte is " + std::to_string(pake.back()) + ", must be 0";
  return {};
}

std::string auth_secret_error(msg::AuthSecret secret) {
  const auto v = static_cast<std::uint8_t>(secret);
  if (v < 1 || v > msg::kLastAuthSecret) return "unknown secret " + std::to_string(v);
  return {};
}

}  // namespace

Status check(const msg::Challenge& m) {
  if ((m.flags & ~msg::kChallengeKnownFlags) != 0)
    return field_error("Challenge", "flags", "unknown flag bits " + std::to_string(m.flags & ~msg::kChallengeKnownFlags));
  if (m.offers.empty() || m.offers.size() > msg::kMaxAuthOffers)
    return field_error("Challenge", "offers",
                       std::to_string(m.offers.size()) + " offers, must be 1 to " + std::to_string(msg::kMaxAuthOffers));
  for (std::size_t i = 0; i < m.offers.size(); ++i) {
    const std::string field = "offers[" + std::to_string(i) + "]";
    if (auto e = auth_secret_error(m.offers[i].secret); !e.empty()) return field_error("Challenge", field + ".secret", e);
    for (std::size_t j = 0; j < i; ++j)
      if (m.offers[j].secret == m.offers[i].secret)
        return field_error("Challenge", field + ".secret", "offered twice (also offers[" + std::to_string(j) + "])");
    if (auto e = pake_framing_error(m.offers[i].pake); !e.empty()) return field_error("Challenge", field + ".pake", e);
  }
  return Ok{};
}

Status check(const msg::AuthProof& m) {
  if (auto e = auth_secret_error(m.secret); !e.empty()) return field_error("AuthProof", "secret", e);
  if (auto e = pake_framing_error(m.pake); !e.empty()) return field_error("AuthProof", "pake", e);
  return Ok{};
}

void write(const msg::Challenge& m, Writer& w) {
  w.raw(m.nonce);
  w.u8(m.flags);
  w.u8(static_cast<std::uint8_t>(m.offers.size()));
  for (const auto& o : m.offers) {
    w.u8(static_cast<std::uint8_t>(o.secret));
    w.raw(o.pake);
  }
}
void write(const msg::AuthProof& m, Writer& w) {
  w.u8(static_cast<std::uint8_t>(m.secret));
  w.raw(m.pake);
  w.raw(m.tag);
}
void write(const msg::AuthConfirm& m, Writer& w) { w.raw(m.tag); }

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

bool read_secret(detail::Reader& r, const char* field, msg::AuthSecret& out) {
  const std::size_t at = r.offset();
  std::uint8_t v = 0;
  if (!r.u8(field, v)) return false;
  out = static_cast<msg::AuthSecret>(v);
  if (auto e = detail::auth_secret_error(out); !e.empty()) return r.fail_at(field, at, e);
  return true;
}

// A CPace message: its fixed size, then its framing bytes (where they are wrong).
bool read_pake(detail::Reader& r, const char* field, msg::PakeMessage& out) {
  const std::size_t at = r.offset();
  if (!read_fixed(r, field, out)) return false;
  if (auto e = detail::pake_framing_error(out); !e.empty())
    return r.fail_at(field, out.front() != msg::kPakePointBytes ? at : at + msg::kPakeMessageBytes - 1, e);
  return true;
}

}  // namespace

// The reads record the first failure with its field and offset; check() then states the
// schema's rules (known flags and secrets, the offers' count, the CPace framing).
Expected<msg::Challenge> decode_challenge(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "Challenge");
  msg::Challenge m;
  read_fixed(r, "nonce", m.nonce);
  r.u8("flags", m.flags);
  if (r.ok() && (m.flags & ~msg::kChallengeKnownFlags) != 0)
    r.fail_at("flags", msg::kAuthNonceBytes, "unknown flag bits " + std::to_string(m.flags & ~msg::kChallengeKnownFlags));
  std::uint8_t n = 0;
  const std::size_t count_at = r.offset();
  r.u8("offers", n);
  if (r.ok() && (n == 0 || n > msg::kMaxAuthOffers))
    r.fail_at("offers", count_at, std::to_string(n) + " offers, must be 1 to " + std::to_string(msg::kMaxAuthOffers));
  for (std::uint8_t i = 0; r.ok() && i < n; ++i) {
    msg::AuthOffer o;
    read_secret(r, "offer.secret", o.secret);
    read_pake(r, "offer.pake", o.pake);
    m.offers.push_back(o);
  }
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::AuthProof> decode_auth_proof(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "AuthProof");
  msg::AuthProof m;
  read_secret(r, "secret", m.secret);
  read_pake(r, "pake", m.pake);
  read_fixed(r, "tag", m.tag);
  if (!r.finish()) return r.error();
  return detail::checked(std::move(m));
}

Expected<msg::AuthConfirm> decode_auth_confirm(std::span<const std::uint8_t> body) {
  detail::Reader r(body, "AuthConfirm");
  msg::AuthConfirm m;
  read_fixed(r, "tag", m.tag);
  if (!r.finish()) return r.error();
  return m;
}

}  // namespace gauss::wire
