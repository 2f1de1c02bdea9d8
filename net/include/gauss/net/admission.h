#pragma once
// Admission limits of the host's transport before and at the handshake (NetHost applies
// them; the bookkeeping is here, with time passed in, so it is tested without sockets).
//
// What each limit stops (issue 28, "hostile networks"):
//  - ENet peer slots: max_clients + spare_peers, and at most max_peers_per_address of
//    them, in any state, from one IP address (ENet's own duplicatePeers check): one
//    address cannot take every slot with half-open or silent connections.
//  - pending_timeout: a connect request whose verification is never acknowledged holds
//    a slot this long, not ENet's 30 s; handshake_timeout (NetHostConfig) does the same
//    for a connection that sends no Hello or no proof. When fewer than a reserve of slots
//    are free, the oldest such connections are dropped early (a legitimate client
//    completes both steps within a round trip), so a burst from many addresses leaves
//    room for the next connect.
//  - Online guessing: after a wrong proof, an address waits auth_backoff_initial before
//    its next Hello is challenged, doubling per failure up to auth_backoff_max (forgotten
//    after a quiet period); and the host checks at most proofs_per_second (bucket
//    proof_burst) whatever the address, so many addresses cannot multiply the rate.
//  - Sessions: at most max_clients_per_address handshaken clients per address, and
//    session opens per address from a bucket of session_open_burst refilled at
//    session_open_rate_hz: a session costs the host scene info, the surface and a resync
//    (about 1.5 MB), so a loop of Hellos without a token cannot make it send that
//    endlessly.
//  - stall_timeout: a handshaken client whose incoming data has waited undelivered this
//    long (a reliable channel held back by a sequence gap it never fills) is disconnected
//    and counted as kicked, like one that only sends garbage.
// A legitimate client behind the same address as an attacker shares its limits: the
// per-address limits cannot tell them apart (see docs/DESIGN.md, "Hostile networks").
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>

namespace gauss::net {

struct AdmissionConfig {
  // ENet peer slots beyond max_clients. More than max_peers_per_address times the
  // addresses an attacker plausibly holds: 300 silent connections from 10 addresses fit
  // without crowding anyone out. A slot costs a few hundred bytes until used, and ENet's
  // service walks them all (microseconds at this size).
  std::size_t spare_peers{1024};
  std::size_t max_peers_per_address{32};  // ENet peers from one address, any state
  std::size_t max_clients_per_address{4};  // a headset is one address; loopback tests raise it
  std::chrono::milliseconds pending_timeout{3000};
  std::chrono::milliseconds auth_backoff_initial{1000};
  std::chrono::milliseconds auth_backoff_max{30000};
  double proofs_per_second{10.0};
  double proof_burst{20.0};
  double session_open_rate_hz{1.0};
  double session_open_burst{8.0};
  std::chrono::milliseconds stall_timeout{5000};
  // One summary line per interval with the counts of refused, timed-out and dropped
  // connections (never one line per event: a flood would flood the log too).
  std::chrono::milliseconds summary_interval{10000};
  // Addresses remembered at once (backoff, session buckets, client counts); idle ones are
  // forgotten first. Only addresses that completed ENet's handshake are remembered.
  std::size_t tracked_addresses{4096};
};

// An error naming the first field out of range, or empty.
std::string validate(const AdmissionConfig& c);

// Per-address and global admission state. Not thread-safe (NetHost's service thread).
class AdmissionGuard {
 public:
  using Clock = std::chrono::steady_clock;
  using Address = std::uint32_t;  // IPv4 host in network order, as ENet 1.3 keeps it

  explicit AdmissionGuard(AdmissionConfig config);

  // How long `a` must still wait before a Hello of its is challenged (nullopt: it may).
  std::optional<Clock::duration> auth_blocked(Address a, Clock::time_point now) const;
  // Takes one proof check from the host-wide bucket; false: the host is at its rate.
  bool take_proof(Clock::time_point now);
  // A wrong proof from `a`: its wait doubles (capped). A right one clears it.
  void auth_failed(Address a, Clock::time_point now);
  void auth_passed(Address a);

  // Whether `a` may open another session now (a client slot per address and the
  // session-open bucket); on true, one session open is taken and counted to `a` until
  // client_closed().
  enum class Open { Ok, AddressFull, RateLimited };
  Open open_session(Address a, Clock::time_point now);
  void client_closed(Address a);

  std::size_t tracked() const noexcept { return entries_.size(); }

 private:
  struct Entry {
    std::uint32_t failures{0};
    Clock::time_point last_failure{};
    Clock::time_point blocked_until{};
    double session_tokens{0.0};
    Clock::time_point refilled{};
    std::uint32_t clients{0};
    Clock::time_point touched{};
  };
  Entry& entry(Address a, Clock::time_point now);
  void forget_idle(Clock::time_point now);

  AdmissionConfig cfg_;
  std::unordered_map<Address, Entry> entries_;
  double proof_tokens_;
  Clock::time_point proofs_refilled_{};
  bool proofs_started_{false};
};

}  // namespace gauss::net
