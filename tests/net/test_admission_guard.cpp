// AdmissionGuard (admission.h) on a clock of its own: the backoff doubles and caps, the
// host-wide proof bucket holds whoever asks, per-address sessions are bounded in number
// and rate, and the table of addresses stays bounded.
#include <gtest/gtest.h>

#include "gauss/net/admission.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;
using net::AdmissionConfig;
using net::AdmissionGuard;

TEST(AdmissionGuard, WrongProofsDoubleTheWaitUpToTheCap) {
  AdmissionConfig c;
  c.auth_backoff_initial = 1s;
  c.auth_backoff_max = 8s;
  AdmissionGuard g(c);
  const auto t0 = AdmissionGuard::Clock::time_point{} + 1000s;
  const AdmissionGuard::Address a = 1, other = 2;
  EXPECT_FALSE(g.auth_blocked(a, t0));
  auto t = t0;
  for (auto expected : {1s, 2s, 4s, 8s, 8s, 8s}) {
    g.auth_failed(a, t);
    auto wait = g.auth_blocked(a, t);
    ASSERT_TRUE(wait);
    EXPECT_EQ(*wait, expected);
    EXPECT_TRUE(g.auth_blocked(a, t + expected - 1ms));
    EXPECT_FALSE(g.auth_blocked(a, t + expected));
    EXPECT_FALSE(g.auth_blocked(other, t)) << "another address is not held back";
    t += expected;
  }
  // A right proof clears the streak; so does a long quiet period.
  g.auth_passed(a);
  EXPECT_FALSE(g.auth_blocked(a, t));
  g.auth_failed(a, t);
  g.auth_failed(a, t + 1s);
  t += 1s + 4 * 8s + 1s;
  g.auth_failed(a, t);
  EXPECT_EQ(*g.auth_blocked(a, t), 1s);
}

// The default configuration answers at most a handful of wrong proofs per address in 20 s
// whatever the rate of tries (the bound): 0, 1, 3, 7, 15 s.
TEST(AdmissionGuard, DefaultsAnswerAHandfulOfProofsPerAddressIn20s) {
  AdmissionGuard g(AdmissionConfig{});
  const auto t0 = AdmissionGuard::Clock::time_point{} + 1000s;
  int answered = 0;
  for (auto t = t0; t < t0 + 20s; t += 1ms) {
    if (g.auth_blocked(7, t)) continue;
    if (!g.take_proof(t)) continue;
    ++answered;
    g.auth_failed(7, t);
  }
  EXPECT_EQ(answered, 5);
}

TEST(AdmissionGuard, TheProofBucketCapsTheHostWholeRate) {
  AdmissionConfig c;
  c.proofs_per_second = 10.0;
  c.proof_burst = 20.0;
  AdmissionGuard g(c);
  const auto t0 = AdmissionGuard::Clock::time_point{} + 1000s;
  int taken = 0;
  for (auto t = t0; t < t0 + 10s; t += 1ms) taken += g.take_proof(t) ? 1 : 0;
  EXPECT_GE(taken, 20 + 99);
  EXPECT_LE(taken, 20 + 100);
}

TEST(AdmissionGuard, SessionsPerAddressAreBoundedInNumberAndRate) {
  AdmissionConfig c;
  c.max_clients_per_address = 2;
  c.session_open_burst = 3.0;
  c.session_open_rate_hz = 1.0;
  AdmissionGuard g(c);
  const auto t0 = AdmissionGuard::Clock::time_point{} + 1000s;
  EXPECT_EQ(g.open_session(1, t0), AdmissionGuard::Open::Ok);
  EXPECT_EQ(g.open_session(1, t0), AdmissionGuard::Open::Ok);
  EXPECT_EQ(g.open_session(1, t0), AdmissionGuard::Open::AddressFull);
  EXPECT_EQ(g.open_session(2, t0), AdmissionGuard::Open::Ok) << "per address";
  g.client_closed(1);
  EXPECT_EQ(g.open_session(1, t0), AdmissionGuard::Open::Ok);  // the third of the burst
  g.client_closed(1);
  EXPECT_EQ(g.open_session(1, t0), AdmissionGuard::Open::RateLimited);
  EXPECT_EQ(g.open_session(1, t0 + 1s), AdmissionGuard::Open::Ok);
  // Closing more than was opened never underflows.
  for (int i = 0; i < 5; ++i) g.client_closed(1);
  EXPECT_EQ(g.open_session(1, t0 + 3s), AdmissionGuard::Open::Ok);
}

TEST(AdmissionGuard, TheAddressTableStaysBoundedAndKeepsClientCounts) {
  AdmissionConfig c;
  c.tracked_addresses = 16;
  c.max_clients_per_address = 1;
  AdmissionGuard g(c);
  const auto t0 = AdmissionGuard::Clock::time_point{} + 1000s;
  ASSERT_EQ(g.open_session(999, t0), AdmissionGuard::Open::Ok);
  for (AdmissionGuard::Address a = 0; a < 1000; ++a) g.auth_failed(a, t0 + std::chrono::milliseconds(a));
  EXPECT_LE(g.tracked(), 17u);
  EXPECT_EQ(g.open_session(999, t0 + 2s), AdmissionGuard::Open::AddressFull) << "a connected client's count survives";
}

TEST(AdmissionGuard, ValidateNamesTheBadField) {
  AdmissionConfig c;
  EXPECT_EQ(net::validate(c), "");
  c.auth_backoff_max = 10ms;
  EXPECT_NE(net::validate(c).find("auth_backoff"), std::string::npos);
  c = {};
  c.proofs_per_second = 0.0;
  EXPECT_NE(net::validate(c).find("proofs_per_second"), std::string::npos);
  c = {};
  c.spare_peers = 0;
  EXPECT_NE(net::validate(c).find("spare_peers"), std::string::npos);
}

}  // namespace
}  // namespace gauss
