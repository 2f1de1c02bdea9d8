// CPace over ristretto255 with SHA-512 (cpace.h), following draft-irtf-cfrg-cpace.
#include "gauss/net/cpace.h"

#include <sodium.h>

#include <algorithm>
#include <string_view>

namespace gauss::net::cpace {

namespace {

constexpr std::string_view kDsi = "CPaceRistretto255";
constexpr std::string_view kDsiIsk = "CPaceRistretto255_ISK";
constexpr std::size_t kHashBlockBytes = 128;  // SHA-512's input block (H.s_in_bytes)

Bytes bytes_of(std::string_view s) { return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}; }

void append(std::vector<std::uint8_t>& out, Bytes b) { out.insert(out.end(), b.begin(), b.end()); }

Isk sha512(Bytes first, Bytes second = {}, Bytes third = {}) {
  crypto_hash_sha512_state st;
  crypto_hash_sha512_init(&st);
  crypto_hash_sha512_update(&st, first.data(), first.size());
  crypto_hash_sha512_update(&st, second.data(), second.size());
  crypto_hash_sha512_update(&st, third.data(), third.size());
  Isk out{};
  crypto_hash_sha512_final(&st, out.data());
  return out;
}

// Reads one LEB128 length at `at`; false when it runs past the end or past 2^32.
bool read_len(Bytes msg, std::size_t& at, std::size_t& len) {
  len = 0;
  for (unsigned shift = 0; shift < 32; shift += 7) {
    if (at >= msg.size()) return false;
    const std::uint8_t b = msg[at++];
    len |= std::size_t{b & 0x7Fu} << shift;
    if ((b & 0x80u) == 0) return true;
  }
  return false;
}

}  // namespace

std::vector<std::uint8_t> prepend_len(Bytes data) {
  std::vector<std::uint8_t> out;
  std::size_t len = data.size();
  do {
    const auto low = static_cast<std::uint8_t>(len & 0x7Fu);
    len >>= 7;
    out.push_back(len > 0 ? static_cast<std::uint8_t>(low | 0x80u) : low);
  } while (len > 0);
  append(out, data);
  return out;
}

std::vector<std::uint8_t> prefix_free_cat(std::initializer_list<Bytes> parts) {
  std::vector<std::uint8_t> out;
  for (Bytes p : parts) append(out, prepend_len(p));
  return out;
}

std::vector<std::uint8_t> generator_string(Bytes prs, Bytes ci, Bytes sid) {
  const std::size_t used = prepend_len(prs).size() + prepend_len(bytes_of(kDsi)).size() + 1;
  const std::vector<std::uint8_t> zpad(used < kHashBlockBytes ? kHashBlockBytes - used : 0, 0);
  return prefix_free_cat({bytes_of(kDsi), prs, zpad, ci, sid});
}

Point calculate_generator(Bytes prs, Bytes ci, Bytes sid) {
  const std::vector<std::uint8_t> gen = generator_string(prs, ci, sid);
  Isk h = sha512(gen);
  Point g{};
  crypto_core_ristretto255_from_hash(g.data(), h.data());
  sodium_memzero(h.data(), h.size());
  return g;
}

Scalar sample_scalar() {
  Scalar y{};
  randombytes_buf(y.data(), y.size());
  y[31] &= 0x0F;  // group_size_bits = 252
  return y;
}

Expected<Point> scalar_mult_vfy(const Scalar& y, const Point& x) {
  Point out{};
  // Named apart so that a refusal says which: the identity's encoding is all zeros (it
  // decodes, and would make K the identity whatever y), anything else must decode.
  if (std::all_of(x.begin(), x.end(), [](std::uint8_t b) { return b == 0; }))
    return Error{"CPace point is the identity"};
  if (crypto_core_ristretto255_is_valid_point(x.data()) != 1)
    return Error{"CPace point does not decode to a ristretto255 element"};
  // libsodium also refuses an identity result (not reachable with a valid non-identity
  // point and a scalar below the group order, which is prime).
  if (crypto_scalarmult_ristretto255(out.data(), y.data(), x.data()) != 0)
    return Error{"CPace point gives the identity"};
  return out;
}

std::vector<std::uint8_t> message(const Point& y_public, Bytes ad) { return prefix_free_cat({y_public, ad}); }

Expected<Message> parse_message(Bytes msg) {
  std::size_t at = 0, len_y = 0, len_ad = 0;
  if (!read_len(msg, at, len_y) || len_y != kPointBytes || msg.size() - at < len_y)
    return Error{"CPace message is malformed (the point's length field)"};
  Message m;
  std::copy_n(msg.begin() + static_cast<std::ptrdiff_t>(at), kPointBytes, m.y_public.begin());
  at += kPointBytes;
  if (!read_len(msg, at, len_ad) || msg.size() - at != len_ad)
    return Error{"CPace message is malformed (the associated data's length does not match the message)"};
  m.ad.assign(msg.begin() + static_cast<std::ptrdiff_t>(at), msg.end());
  return m;
}

Isk isk_initiator_responder(Bytes sid, const Point& k, Bytes msg_a, Bytes msg_b) {
  std::vector<std::uint8_t> head = prefix_free_cat({bytes_of(kDsiIsk), sid, k});
  Isk isk = sha512(head, msg_a, msg_b);
  sodium_memzero(head.data(), head.size());
  return isk;
}

Isk isk_parallel(Bytes sid, const Point& k, Bytes msg_a, Bytes msg_b) {
  // oCat: the lexicographically larger string first.
  const bool a_first = std::lexicographical_compare(msg_b.begin(), msg_b.end(), msg_a.begin(), msg_a.end());
  return a_first ? isk_initiator_responder(sid, k, msg_a, msg_b) : isk_initiator_responder(sid, k, msg_b, msg_a);
}

Party start(Bytes prs, Bytes ci, Bytes sid, Bytes ad, const Scalar* y) {
  Party p;
  p.y = y ? *y : sample_scalar();
  const Point g = calculate_generator(prs, ci, sid);
  // g is a valid element and y is not zero modulo the group order (below 2^252, and 0 only
  // with probability 2^-252), so the product is never the identity.
  const Expected<Point> y_public = scalar_mult_vfy(p.y, g);
  p.msg = message(y_public ? *y_public : Point{}, ad);
  return p;
}

namespace {

Expected<Isk> finish(const Party& self, Bytes sid, Bytes other, bool initiator) {
  auto m = parse_message(other);
  if (!m) return m.error();
  auto k = scalar_mult_vfy(self.y, m->y_public);
  if (!k) return k.error();
  Isk isk = initiator ? isk_initiator_responder(sid, *k, self.msg, other) : isk_initiator_responder(sid, *k, other, self.msg);
  sodium_memzero(k->data(), k->size());
  return isk;
}

}  // namespace

Expected<Isk> finish_initiator(const Party& a, Bytes sid, Bytes msg_b) { return finish(a, sid, msg_b, true); }
Expected<Isk> finish_responder(const Party& b, Bytes sid, Bytes msg_a) { return finish(b, sid, msg_a, false); }

}  // namespace gauss::net::cpace
