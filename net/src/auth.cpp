// The handshake's CPace exchange, key confirmation and key schedule (see auth.h), on
// libsodium's BLAKE2b and cpace.h.
#include "gauss/net/auth.h"

#include <sodium.h>

#include <algorithm>
#include <cctype>

#include "gauss/engine/wire.h"

namespace gauss::net {

namespace {

constexpr std::string_view kPrkDomain = "gauss-pake-v1";
constexpr std::string_view kClientConfirm = "gauss-pake-v1 client confirm";
constexpr std::string_view kHostConfirm = "gauss-pake-v1 host confirm";
constexpr std::string_view kHostToClient = "gauss-pake-v1 host to client";
constexpr std::string_view kClientToHost = "gauss-pake-v1 client to host";

constexpr char kCrockford[] = "0123456789abcdefghjkmnpqrstvwxyz";

static_assert(msg::kPakePointBytes == cpace::kPointBytes);
static_assert(std::tuple_size_v<cpace::Isk> <= crypto_generichash_KEYBYTES_MAX);
static_assert(msg::kAuthTagBytes >= crypto_generichash_BYTES_MIN && msg::kAuthTagBytes <= crypto_generichash_BYTES_MAX);

cpace::Bytes bytes_of(std::string_view s) { return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}; }

// BLAKE2b keyed with `key`, of `data`, `out.size()` bytes long.
void keyed_hash(std::span<std::uint8_t> out, std::span<const std::uint8_t> key, std::span<const std::uint8_t> data) {
  crypto_generichash(out.data(), out.size(), data.data(), data.size(), key.data(), key.size());
}

// The wire form of a CPace message with no associated data (messages.h, kPakeMessageBytes).
msg::PakeMessage to_wire(const std::vector<std::uint8_t>& m) {
  msg::PakeMessage out{};
  if (m.size() == out.size()) std::copy(m.begin(), m.end(), out.begin());
  return out;
}

// A secret's PRS: the token's bytes, or the code's canonical symbols.
std::string prs_of(msg::AuthSecret secret, std::string_view value) {
  if (secret == msg::AuthSecret::PairingCode) return canonical_pairing_code(value).value_or(std::string{});
  return std::string(value);
}

std::string random_symbols(std::size_t n) {
  std::vector<std::uint8_t> bytes(n);
  randombytes_buf(bytes.data(), bytes.size());
  std::string out;
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0 && i % 4 == 0) out += '-';
    out += kCrockford[bytes[i] & 31u];  // 256 is a multiple of 32: every symbol equally likely
  }
  sodium_memzero(bytes.data(), bytes.size());
  return out;
}

}  // namespace

Status auth_init() {
  if (sodium_init() < 0) return Error{"libsodium could not be initialised"};
  return Ok{};
}

SessionKeys::~SessionKeys() {
  sodium_memzero(client_tag.data(), client_tag.size());
  sodium_memzero(host_tag.data(), host_tag.size());
  sodium_memzero(host_to_client.data(), host_to_client.size());
  sodium_memzero(client_to_host.data(), client_to_host.size());
}

SessionKeys derive_session_keys(const cpace::Isk& isk, std::span<const std::uint8_t> hello_frame,
                                std::span<const std::uint8_t> challenge_frame, msg::AuthSecret secret) {
  const std::uint8_t secret_byte = static_cast<std::uint8_t>(secret);
  std::vector<std::uint8_t> info =
      cpace::prefix_free_cat({bytes_of(kPrkDomain), hello_frame, challenge_frame, {&secret_byte, 1}});
  std::array<std::uint8_t, crypto_generichash_BYTES_MAX> prk{};
  keyed_hash(prk, isk, info);
  SessionKeys k;
  keyed_hash(k.client_tag, prk, bytes_of(kClientConfirm));
  keyed_hash(k.host_tag, prk, bytes_of(kHostConfirm));
  keyed_hash(k.host_to_client, prk, bytes_of(kHostToClient));
  keyed_hash(k.client_to_host, prk, bytes_of(kClientToHost));
  sodium_memzero(prk.data(), prk.size());
  return k;
}

HostHandshake::HostHandshake(const AuthSecrets& secrets, std::span<const std::uint8_t> hello_frame, std::uint8_t flags,
                             const std::array<std::uint8_t, msg::kAuthNonceBytes>* nonce)
    : hello_frame_(hello_frame.begin(), hello_frame.end()) {
  if (nonce) challenge_.nonce = *nonce;
  else randombytes_buf(challenge_.nonce.data(), challenge_.nonce.size());
  challenge_.flags = flags;
  auto offer = [&](msg::AuthSecret secret, std::string_view value) {
    const std::string prs = prs_of(secret, value);
    if (value.empty() || prs.empty()) return;
    Offer o{secret, cpace::start(bytes_of(prs), hello_frame_, challenge_.nonce, {})};
    challenge_.offers.push_back(msg::AuthOffer{secret, to_wire(o.party.msg)});
    offers_.push_back(std::move(o));
  };
  offer(msg::AuthSecret::AccessToken, secrets.access_token);
  offer(msg::AuthSecret::PairingCode, secrets.pairing_code);
  // Encoding fails only for a Challenge without offers (no secret): the proof then finds
  // no offer and is refused.
  auto frame = wire::encode(challenge_);
  if (frame) challenge_frame_ = std::move(frame).value();
}

HostHandshake::~HostHandshake() {
  for (auto& o : offers_) sodium_memzero(o.party.y.data(), o.party.y.size());
}

Expected<SessionKeys> HostHandshake::verify(const msg::AuthProof& proof) const {
  const auto it = std::find_if(offers_.begin(), offers_.end(), [&](const Offer& o) { return o.secret == proof.secret; });
  if (it == offers_.end()) return Error{"the proof answers a secret this host did not offer"};
  auto isk = cpace::finish_initiator(it->party, challenge_.nonce, proof.pake);
  if (!isk) return Error{"the client's " + isk.message()};
  SessionKeys keys = derive_session_keys(*isk, hello_frame_, challenge_frame_, proof.secret);
  sodium_memzero(isk->data(), isk->size());
  if (sodium_memcmp(keys.client_tag.data(), proof.tag.data(), keys.client_tag.size()) != 0)
    return Error{"the key confirmation does not match (a wrong access token or pairing code)"};
  return keys;
}

Expected<ClientAnswer> answer_challenge(std::string_view secret, std::span<const std::uint8_t> challenge_frame,
                                        std::span<const std::uint8_t> hello_frame, const cpace::Scalar* y) {
  auto decoded = wire::decode(challenge_frame);
  if (!decoded) return decoded.error();
  const auto* challenge = std::get_if<msg::Challenge>(&decoded.value());
  if (challenge == nullptr) return Error{"not a Challenge"};
  auto find = [&](msg::AuthSecret s) {
    return std::find_if(challenge->offers.begin(), challenge->offers.end(),
                        [&](const msg::AuthOffer& o) { return o.secret == s; });
  };
  auto offer = challenge->offers.end();
  if (canonical_pairing_code(secret)) offer = find(msg::AuthSecret::PairingCode);
  if (offer == challenge->offers.end()) offer = find(msg::AuthSecret::AccessToken);
  if (offer == challenge->offers.end())
    return Error{"the host asks for a pairing code (8 symbols, as it printed them), and the secret given is not one"};
  const std::string prs = prs_of(offer->secret, secret);
  const cpace::Party party = cpace::start(bytes_of(prs), hello_frame, challenge->nonce, {}, y);
  auto isk = cpace::finish_responder(party, challenge->nonce, offer->pake);
  if (!isk) return Error{"the host's " + isk.message()};
  ClientAnswer a;
  a.keys = derive_session_keys(*isk, hello_frame, challenge_frame, offer->secret);
  sodium_memzero(isk->data(), isk->size());
  a.proof.secret = offer->secret;
  a.proof.pake = to_wire(party.msg);
  a.proof.tag = a.keys.client_tag;
  return a;
}

bool host_confirmed(const SessionKeys& keys, const msg::AuthConfirm& confirm) {
  return sodium_memcmp(keys.host_tag.data(), confirm.tag.data(), keys.host_tag.size()) == 0;
}

std::string generate_access_token() { return random_symbols(26); }

std::string generate_pairing_code() { return random_symbols(kPairingCodeSymbols); }

std::optional<std::string> canonical_pairing_code(std::string_view typed) {
  std::string out;
  for (const char ch : typed) {
    if (ch == '-' || ch == ' ') continue;
    char c = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (c == 'i' || c == 'l') c = '1';
    if (c == 'o') c = '0';
    if (std::string_view(kCrockford).find(c) == std::string_view::npos) return std::nullopt;
    out += c;
    if (out.size() > kPairingCodeSymbols) return std::nullopt;
  }
  if (out.size() != kPairingCodeSymbols) return std::nullopt;
  return out;
}

std::optional<std::string> weak_token_reason(std::string_view token) {
  if (token.size() >= kStrongTokenChars) return std::nullopt;
  return "a token of " + std::to_string(token.size()) +
         " characters is within reach of online guessing (the host checks up to 10 guesses per second from "
         "everyone together); use at least " + std::to_string(kStrongTokenChars) +
         " random characters, or --token auto";
}

}  // namespace gauss::net
