#pragma once
// CPace, the balanced PAKE of draft-irtf-cfrg-cpace, cipher suite CPACE-RISTR255-SHA512, on
// libsodium's ristretto255 and SHA-512 (issue 28: the token handshake's replacement, so that
// neither an observer nor an active attacker can test token guesses offline, and session
// keys come from ephemeral secrets). The primitive, checked byte for byte against the draft's
// ristretto255 test vectors, those of its revisions that name the encoding lv_cat
// (tests/net/test_cpace.cpp says why not an older revision's); auth.h runs the handshake on it.
//
// Both parties hold PRS (the token), a channel identifier CI and a session id sid. Each
// samples a scalar y, sends MSG = prefix_free_cat(g^y, AD) with g a generator derived from
// PRS, CI and sid, and derives
//   K   = Y_other^y                (refused when Y_other does not decode or K is the identity)
//   ISK = SHA-512(prefix_free_cat("CPaceRistretto255_ISK", sid, K) || MSGa || MSGb)
// (initiator/responder order; ISK is the "intermediate session key": derive keys from it).
// A wrong PRS gives unrelated ISKs, and nothing in the transcript lets a guess be tested
// without running the protocol with a party that knows PRS.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss::net::cpace {

inline constexpr std::size_t kPointBytes = 32;   // an encoded ristretto255 element
inline constexpr std::size_t kScalarBytes = 32;  // little endian, below 2^252
inline constexpr std::size_t kIskBytes = 64;     // SHA-512

using Point = std::array<std::uint8_t, kPointBytes>;
using Scalar = std::array<std::uint8_t, kScalarBytes>;
using Isk = std::array<std::uint8_t, kIskBytes>;
using Bytes = std::span<const std::uint8_t>;

// The draft's encodings: the length as LEB128 then the bytes; several such, concatenated.
std::vector<std::uint8_t> prepend_len(Bytes data);
std::vector<std::uint8_t> prefix_free_cat(std::initializer_list<Bytes> parts);
// prefix_free_cat(DSI, PRS, zero padding to SHA-512's 128-byte block, CI, sid).
std::vector<std::uint8_t> generator_string(Bytes prs, Bytes ci, Bytes sid);
// The encoded generator: ristretto255's one-way map of SHA-512(generator_string).
Point calculate_generator(Bytes prs, Bytes ci, Bytes sid);
// 32 random bytes with the bits from 252 up cleared (the draft's recommendation).
Scalar sample_scalar();
// encode(decode(x)^y); an error naming which when x is the identity, x does not decode or
// the result is the identity (the draft's scalar_mult_vfy returning G.I, on which a party
// MUST abort).
Expected<Point> scalar_mult_vfy(const Scalar& y, const Point& x);
// MSG = prefix_free_cat(Y, AD), and its parse (exact lengths, a 32-byte Y, or an error).
std::vector<std::uint8_t> message(const Point& y_public, Bytes ad);
struct Message {
  Point y_public{};
  std::vector<std::uint8_t> ad;
};
Expected<Message> parse_message(Bytes msg);
// ISK for the initiator/responder order (MSGa sent first) and for the parallel order
// (oCat: the lexicographically larger message first).
Isk isk_initiator_responder(Bytes sid, const Point& k, Bytes msg_a, Bytes msg_b);
Isk isk_parallel(Bytes sid, const Point& k, Bytes msg_a, Bytes msg_b);

// One party's side: its secret scalar and its message.
struct Party {
  Scalar y{};
  std::vector<std::uint8_t> msg;
};
// Starts a party (a fresh scalar unless `y` is given: tests). Requires auth_init().
Party start(Bytes prs, Bytes ci, Bytes sid, Bytes ad, const Scalar* y = nullptr);
// The initiator's ISK from the responder's message, and the responder's from the
// initiator's. Errors: a malformed message, a point that does not decode, K the identity.
Expected<Isk> finish_initiator(const Party& a, Bytes sid, Bytes msg_b);
Expected<Isk> finish_responder(const Party& b, Bytes sid, Bytes msg_a);

}  // namespace gauss::net::cpace
