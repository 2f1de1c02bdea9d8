#pragma once
// NetHost: the host end of the ENet transport. Thin by design: it owns the socket,
// one service thread, the transport half of the handshake and per-connection
// hygiene (malformed, wrong-direction and flooding input is rejected, logged and
// counted). Everything else -- accepting the Hello, what to select, diff and send
// per client -- is the caller's policy (engine HostSession), fed through poll()
// events and send(); SessionHost (session_host.h) wires the two together.
//
// Handshake: the first message of a connection must be a Hello of this protocol
// version, within handshake_timeout, while fewer than max_clients are connected;
// when an access_token (or a pairing_code) is configured here, the host answers that
// Hello with a Challenge and the client must prove the secret (CPace, gauss/net/auth.h)
// with an AuthProof within the same timeout; the host then proves it in turn
// (AuthConfirm). The secret never crosses the wire and nothing on it lets a guess be
// tested offline (a Hello carrying a token is refused). With encrypt_stream the Challenge
// says so, and every frame after the handshake travels sealed both ways under keys from
// the exchange (stream_cipher.h); a plain or altered one is rejected. Otherwise the host
// answers Refuse and disconnects, and the policy never hears of it. A failed proof is
// refused as "authentication failed: <what was wrong with the proof>" before anything
// else about the Hello is judged. A Hello that passes becomes a Connected event with a
// fresh client id; the policy then replies with Welcome (or Refuse: a Refuse sent through
// send() closes the connection after it is delivered).
//
// Before and at the handshake the admission limits apply (admission.h: peer slots,
// per-address limits, connect-request and handshake timeouts, the backoff after a wrong
// proof, session-open rates, stalled channels); what they refuse and drop is counted and
// summarised in one log line per interval, never logged per event.
//
// Threading: only the service thread touches ENet. send(), poll(), wait() and
// counters() are thread-safe; messages are encoded on the caller's thread, so a big
// edit batch never stalls the service loop.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"
#include "gauss/engine/slot_table.h"
#include "gauss/engine/wire.h"
#include "gauss/net/address.h"
#include "gauss/net/admission.h"

namespace gauss::net {

using LogFn = std::function<void(const std::string&)>;

struct NetHostConfig {
  Endpoint bind{};                    // loopback by default; port 0 = any free port (see port())
  std::string access_token;           // non-empty: clients must prove it (CPace, auth.h) here
  // A second secret clients may prove instead: kPairingCodeSymbols Crockford base32
  // symbols a person can type on a headset (gauss-host --token auto prints one). Empty:
  // none. The access token must then not look like a code.
  std::string pairing_code;
  // Seal every frame after the handshake, both ways (stream_cipher.h): for private
  // scenes. Needs a secret (the keys come from the exchange that proves it).
  bool encrypt_stream{false};
  std::size_t max_clients{16};        // handshaken clients at once; more are refused (HostFull)
  std::uint32_t max_slot_capacity{gauss::kMaxSlotCapacity};  // larger requests are refused
  // Transport flood guard per client: a token bucket of `query_burst` refilled at
  // `query_rate_hz`. An over-limit query is answered QueryStatus::Rejected and never
  // reaches the policy (which applies its own, tighter rate limit to what passes).
  double query_rate_hz{20.0};
  double query_burst{40.0};
  // Every message from a client (poses, acks, stats, queries) draws from a second bucket:
  // a well-behaved client sends ~10 poses, a few acks and a stats line per second, so
  // 200/s with a burst of 400 is far above it, while a flood is cut off at the transport
  // (rejected, counted as message_flood, and kicked with the other rejections) before it
  // can fill the policy's event queue that every client shares.
  double message_rate_hz{200.0};
  double message_burst{400.0};
  // More rejected messages than this from one client and it is disconnected: a peer
  // that only sends garbage costs the host nothing more.
  std::uint32_t max_rejected_per_client{256};
  // A connection that sends no Hello (or, with a token, no proof) within this time is
  // dropped at once (no disconnect handshake: a silent peer would not answer it). A
  // client sends its Hello on connect and its proof one round trip later.
  std::chrono::milliseconds handshake_timeout{3000};
  // Peer slots, per-address limits, connect-request timeout, guessing backoff, session
  // rate, stalled channels and the summary log line (admission.h).
  AdmissionConfig admission{};
  // ENet peer timeout bounds: a crashed client is noticed after at most `peer_timeout_max`.
  std::chrono::milliseconds peer_timeout_min{2000};
  std::chrono::milliseconds peer_timeout_max{8000};
  // Queued events (messages for the policy) beyond this are dropped and counted.
  std::size_t max_queued_events{1u << 16};
  std::uint64_t session_id{0};        // 0: drawn at start (a new value tells clients the host restarted)
  LogFn log;                          // empty: stderr
};

// Counters of everything the host accepted and rejected, by reason. Events before a
// client is handshaken are never logged one by one (a flood would flood the log): one
// summary line per AdmissionConfig::summary_interval gives the counts that changed.
struct HostCounters {
  std::uint64_t connections{0};        // ENet connects
  std::uint64_t accepted{0};           // Hellos passed to the policy
  std::uint64_t refused_by_policy{0};  // Refuse messages the policy sent
  std::uint64_t refused_version{0};
  std::uint64_t refused_token{0};
  std::uint64_t refused_capacity{0};
  std::uint64_t refused_full{0};
  std::uint64_t refused_malformed{0};  // first message not a valid Hello
  std::uint64_t refused_backoff{0};       // Hellos from an address still waiting after a wrong proof
  std::uint64_t refused_proof_rate{0};    // Hellos over the host-wide proof rate
  std::uint64_t refused_address_full{0};  // max_clients_per_address reached
  std::uint64_t refused_session_rate{0};  // session opens over the per-address rate
  std::uint64_t handshake_timeouts{0};    // connected, no Hello / proof in time
  std::uint64_t handshake_evicted{0};     // the same, dropped early while peer slots ran short
  std::uint64_t pending_timeouts{0};      // connect requests never acknowledged (ENet handshake)
  std::uint64_t pending_evicted{0};       // the same, dropped early while peer slots ran short
  std::uint64_t refusals_dropped{0};      // refused peers that did not take their Refuse and leave
  std::uint64_t disconnects{0};        // handshaken clients gone (either side, or timeout)
  std::uint64_t messages_received{0};  // valid messages handed to the policy
  std::uint64_t malformed{0};          // undecodable messages after the handshake
  std::uint64_t wrong_direction{0};    // host->client types sent by a client (Hello again included)
  std::uint64_t query_flood{0};        // queries over the rate limit
  std::uint64_t message_flood{0};      // messages over the per-client message rate
  std::uint64_t events_dropped{0};     // poll() queue full
  std::uint64_t kicked{0};             // clients disconnected for too many rejections or a stall
  std::uint64_t stalled{0};            // of those, input held undelivered past stall_timeout
  std::uint64_t messages_sent{0};
  std::uint64_t bytes_sent{0};
  std::uint64_t bytes_received{0};
  std::uint64_t send_dropped{0};       // send() to a client that was gone by the time it flushed
  std::uint64_t summaries{0};          // summary lines logged
  std::string last_rejection;          // reason of the newest rejection, for tests and logs
  std::uint64_t rejected() const {
    return malformed + wrong_direction + query_flood + message_flood;
  }
  std::uint64_t refused() const {
    return refused_version + refused_token + refused_capacity + refused_full + refused_malformed + refused_backoff +
           refused_proof_rate + refused_address_full + refused_session_rate;
  }
};

enum class HostEventKind : std::uint8_t { Connected, Message, Disconnected };

struct HostEvent {
  HostEventKind kind{HostEventKind::Message};
  std::uint32_t client{0};     // msg::Welcome::client_id
  msg::Hello hello;            // Connected: the Hello, for the policy to answer
  wire::Message message;       // Message
  std::string reason;          // Disconnected
};

class NetHost {
 public:
  // Binds and starts the service thread. Fails (naming the address) when the port
  // cannot be bound or the config is invalid.
  static Expected<std::unique_ptr<NetHost>> start(NetHostConfig config);
  ~NetHost();  // disconnects every client politely, stops the thread
  NetHost(const NetHost&) = delete;
  NetHost& operator=(const NetHost&) = delete;

  std::uint16_t port() const noexcept;
  std::uint64_t session_id() const noexcept;

  // Events since the last call, oldest first.
  std::vector<HostEvent> poll();
  // Blocks until an event is queued or `timeout` passes; true when one is queued.
  bool wait(std::chrono::milliseconds timeout);

  // Encodes and queues `m` for client `client` on the message's schema channel
  // (reliable). A Refuse closes the connection once it is delivered.
  // Fails on a message the schema refuses or a client->host type; a client that has
  // gone by flush time is counted (send_dropped), not an error.
  Status send(std::uint32_t client, const wire::Message& m);
  // Queues an already encoded frame (the caller encoded once for several clients).
  Status send_encoded(std::uint32_t client, msg::MessageType type, std::shared_ptr<const std::vector<std::uint8_t>> frame);
  // Disconnects a client (after its queued messages are flushed).
  void disconnect(std::uint32_t client);
  // Bytes queued in ENet for the client not yet acknowledged (0 when unknown/gone).
  std::size_t pending_bytes(std::uint32_t client) const;
  std::size_t client_count() const;

  HostCounters counters() const;

 private:
  struct Impl;
  explicit NetHost(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss::net
