// CPace over ristretto255 / SHA-512 (net/cpace.h) against the test vectors of
// draft-irtf-cfrg-cpace ("Test vector for CPace using group ristretto255 and hash
// SHA-512", the revisions that name the encoding lv_cat: generator 5e25411c...), byte for
// byte, then the protocol's own promises: equal ISKs exactly when the PRS, CI, sid and
// transcript match; malformed messages, invalid points and the identity refused.
// (An older revision of the draft's appendix lists generator 9c571217... for the same hash:
// not RFC 9496's one-way map, which libsodium implements and which matches RFC 9496's own
// vector; the later revisions agree with it, and so does this code.)
#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/net/auth.h"
#include "gauss/net/cpace.h"

namespace gauss {
namespace {

namespace cp = net::cpace;

std::vector<std::uint8_t> hex(std::string_view h) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < h.size(); i += 2) out.push_back(static_cast<std::uint8_t>(std::stoi(std::string(h.substr(i, 2)), nullptr, 16)));
  return out;
}
template <std::size_t N>
std::array<std::uint8_t, N> hex_array(std::string_view h) {
  const auto v = hex(h);
  std::array<std::uint8_t, N> out{};
  EXPECT_EQ(v.size(), N) << h;
  std::copy_n(v.begin(), std::min(N, v.size()), out.begin());
  return out;
}
cp::Bytes text(std::string_view s) { return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}; }
std::vector<std::uint8_t> vec(cp::Bytes b) { return {b.begin(), b.end()}; }

// The draft's inputs.
const std::string kPrs = "Password";
const std::string kCi = "\nAinitiator\nBresponder";
const std::vector<std::uint8_t> kSid = hex("7e4b4791d6a8ef019b936c79fb7f2c57");

TEST(CPace, GeneratorMatchesTheDraft) {
  ASSERT_TRUE(net::auth_init().ok());
  EXPECT_EQ(cp::generator_string(text(kPrs), text(kCi), kSid),
            hex("11435061636552697374726574746f3235350850617373776f726464"
                "00000000000000000000000000000000000000000000000000000000"
                "00000000000000000000000000000000000000000000000000000000"
                "00000000000000000000000000000000000000000000000000000000"
                "00000000000000000000000000000000160a41696e69746961746f72"
                "0a42726573706f6e646572107e4b4791d6a8ef019b936c79fb7f2c57"));
  EXPECT_EQ(cp::calculate_generator(text(kPrs), text(kCi), kSid),
            hex_array<32>("5e25411ca1ad7c9debfd0b33ad987a95cefef2d3f15dcc8bd26415a5dfe2e15a"));
}

TEST(CPace, MessagesSecretAndKeysMatchTheDraft) {
  ASSERT_TRUE(net::auth_init().ok());
  const auto ya = hex_array<32>("da3d23700a9e5699258aef94dc060dfda5ebb61f02a5ea77fad53f4ff0976d08");
  const auto yb = hex_array<32>("d2316b454718c35362d83d69df6320f38578ed5984651435e2949762d900b80d");
  const cp::Party a = cp::start(text(kPrs), text(kCi), kSid, text("ADa"), &ya);
  const cp::Party b = cp::start(text(kPrs), text(kCi), kSid, text("ADb"), &yb);
  EXPECT_EQ(a.msg, hex("20383a85dd236978f17f8c8545b50dabc52a39fcdab2cf8bc531ce040ff77ca82d03414461"));
  EXPECT_EQ(b.msg, hex("20a6206309c0e8e5f579295e35997ac4300ab3fecec3c17f7b604f3e698fa1383c03414462"));
  const auto yb_public = cp::parse_message(b.msg);
  ASSERT_TRUE(yb_public.ok());
  const auto k = cp::scalar_mult_vfy(ya, yb_public->y_public);
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(*k, hex_array<32>("fa1d0318864e2cacb26875f1b791c9ae83204fe8359addb53e95a2e98893853f"));
  const auto isk_ir = hex_array<64>(
      "e91ccb2c0f5e0d0993a33956e3be59754f3f2b07db57631f5394452ea2e7b4354674eb1f5686c078462bf83bec72e8743df440108e638f35"
      "26d9b90e85be096f");
  auto ia = cp::finish_initiator(a, kSid, b.msg);
  auto ib = cp::finish_responder(b, kSid, a.msg);
  ASSERT_TRUE(ia.ok() && ib.ok());
  EXPECT_EQ(*ia, isk_ir);
  EXPECT_EQ(*ib, isk_ir);
  EXPECT_EQ(cp::isk_parallel(kSid, *k, a.msg, b.msg),
            (hex_array<64>("2472dedbff868bfc12b4c256f790539af0e2bab7efc28d1a995d18a1a58e5bec639273d4604512669ab79531"
                           "53d437eb90314dcba753972402b0d9c5ec5283f8")));
}

TEST(CPace, ScalarMultVfyMatchesTheDraftAndRefusesInvalidPointsAndTheIdentity) {
  ASSERT_TRUE(net::auth_init().ok());
  const auto s = hex_array<32>("7cd0e075fa7955ba52c02759a6c90dbbfc10e6d40aea8d283e407d88cf538a05");
  const auto x = hex_array<32>("2c3c6b8c4f3800e7aef6864025b4ed79bd599117e427c41bd47d93d654b4a51c");
  const auto good = cp::scalar_mult_vfy(s, x);
  ASSERT_TRUE(good.ok()) << good.message();
  EXPECT_EQ(*good, hex_array<32>("7c13645fe790a468f62c39beb7388e541d8405d1ade69d1778c5fe3e7f6b600e"));
  EXPECT_FALSE(cp::scalar_mult_vfy(s, hex_array<32>("2b3c6b8c4f3800e7aef6864025b4ed79bd599117e427c41bd47d93d654b4a51c")).ok());
  EXPECT_FALSE(cp::scalar_mult_vfy(s, cp::Point{}).ok()) << "the identity's encoding";
  // A party given such a point in the other's message aborts.
  const cp::Party a = cp::start(text(kPrs), text(kCi), kSid, {});
  EXPECT_FALSE(cp::finish_initiator(a, kSid, cp::message(cp::Point{}, {})).ok());
}

TEST(CPace, MessagesWithWrongLengthFieldsAreRefused) {
  const auto y = hex_array<32>("383a85dd236978f17f8c8545b50dabc52a39fcdab2cf8bc531ce040ff77ca82d");
  const std::vector<std::uint8_t> good = cp::message(y, text("ADa"));
  ASSERT_TRUE(cp::parse_message(good).ok());
  EXPECT_EQ(cp::parse_message(good)->ad, vec(text("ADa")));
  std::vector<std::uint8_t> longer = good, shorter = good, wrong_y = good;
  longer.push_back(0);
  shorter.pop_back();
  wrong_y[0] = 31;
  EXPECT_FALSE(cp::parse_message(longer).ok());
  EXPECT_FALSE(cp::parse_message(shorter).ok());
  EXPECT_FALSE(cp::parse_message(wrong_y).ok());
  EXPECT_FALSE(cp::parse_message({}).ok());
  const std::vector<std::uint8_t> endless(40, 0xFF);  // a length field that never ends
  EXPECT_FALSE(cp::parse_message(endless).ok());
  // Lengths of 128 bytes and more take two LEB128 bytes.
  const std::vector<std::uint8_t> ad(300, 7);
  const auto big = cp::message(y, ad);
  EXPECT_EQ(big.size(), 1 + 32 + 2 + 300u);
  ASSERT_TRUE(cp::parse_message(big).ok());
  EXPECT_EQ(cp::parse_message(big)->ad, ad);
}

TEST(CPace, KeysAgreeExactlyWhenEverythingShared) {
  ASSERT_TRUE(net::auth_init().ok());
  auto run = [](std::string_view prs_a, std::string_view prs_b, const std::vector<std::uint8_t>& sid_b) {
    const cp::Party a = cp::start(text(prs_a), text(kCi), kSid, text("client"));
    const cp::Party b = cp::start(text(prs_b), text(kCi), sid_b, text("host"));
    auto ia = cp::finish_initiator(a, kSid, b.msg);
    auto ib = cp::finish_responder(b, sid_b, a.msg);
    EXPECT_TRUE(ia.ok() && ib.ok());
    return ia.ok() && ib.ok() && *ia == *ib;
  };
  EXPECT_TRUE(run("k3f9-x2ab", "k3f9-x2ab", kSid));
  EXPECT_FALSE(run("k3f9-x2ab", "k3f9-x2ac", kSid)) << "another token";
  EXPECT_FALSE(run("k3f9-x2ab", "k3f9-x2ab", hex("00"))) << "another session id";
  // Fresh scalars: two runs with the same token share no key (forward secrecy rests on it).
  const cp::Party a1 = cp::start(text("t"), text(kCi), kSid, {}), a2 = cp::start(text("t"), text(kCi), kSid, {});
  EXPECT_NE(a1.msg, a2.msg);
}

}  // namespace
}  // namespace gauss
