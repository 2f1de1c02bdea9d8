#pragma once
// NetClient: the client's network service. It runs on its own thread, outside the
// display loop: it connects, says Hello, decodes everything the host sends and hands
// it to a ClientSink on that thread. The sink updates CPU-side state only (desired
// state, queues); nothing here ever touches the GPU.
//
// When the connection drops (host restart, network loss, peer timeout), the service
// reconnects with the same Hello unless it was refused; each new Welcome starts a
// resynchronisation (see msg::Welcome). Attempts that do not reach a Welcome back off
// exponentially (reconnect_delay doubling to reconnect_delay_max between attempts; a
// Welcome resets it), so a host that is down for minutes costs one attempt every few
// seconds. A host that refuses for now (full, or too many new sessions) is retried the
// same way. The log gets one line per change of state (connected, lost, unreachable,
// refused), never one per attempt. The display loop never waits on any of this.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"
#include "gauss/engine/wire.h"
#include "gauss/net/address.h"

namespace gauss::net {

struct NetClientConfig {
  Endpoint server{};                 // the host (or a relay in front of it)
  std::uint32_t slot_capacity{0};    // M, sent in Hello
  std::string access_token;
  std::string name{"client"};
  // Reconnect after a drop, and after a refusal that may pass (msg::refusal_is_transient:
  // the host full, or opening sessions too fast); never after any other Refuse.
  bool reconnect{true};
  // Wait before the next attempt: reconnect_delay after a welcomed connection drops (a
  // host restart is usually back within a second), then doubled after every attempt that
  // got no Welcome, up to reconnect_delay_max (4 s: a host that stays down costs one
  // attempt per ~7 s with connect_timeout, and one that comes back is found within that).
  std::chrono::milliseconds reconnect_delay{250};
  std::chrono::milliseconds reconnect_delay_max{4000};
  // One attempt's wait for the transport connection. ENet resends its connect request
  // at ~0.5, 1.5, 3.5 s, so 3 s covers three tries (a host coming up mid-attempt is met).
  std::chrono::milliseconds connect_timeout{3000};
  // ENet peer timeout bounds: a vanished host is noticed after at most the max.
  std::chrono::milliseconds peer_timeout_min{2000};
  std::chrono::milliseconds peer_timeout_max{8000};
  std::function<void(const std::string&)> log;  // empty: stderr
};

// Called on the network thread, one call at a time.
class ClientSink {
 public:
  virtual ~ClientSink() = default;
  virtual void on_welcome(const msg::Welcome& welcome) = 0;
  // A host->client message after the Welcome (never Welcome/Refuse themselves).
  virtual void on_message(wire::Message&& message) = 0;
  virtual void on_refused(const msg::Refuse& refuse) = 0;
  virtual void on_disconnected(const std::string& reason) = 0;
  // Polled by the network thread while connected: client->host messages (acks,
  // poses, queries, stats) the sink's state queued since the last call.
  virtual std::vector<wire::Message> take_outgoing() { return {}; }
};

// Connecting: before the first Welcome, and again while reconnecting after a drop (then
// counters().disconnects > 0: the client is disconnected and shows its last state).
// Connected: welcomed. Refused: final, no more attempts. Stopped: the service ended. A
// transient refusal (the host full) leaves the client Connecting, retrying, with
// counters().turned_away and last_rejection saying why.
enum class ClientStatus : std::uint8_t { Connecting, Connected, Refused, Stopped };

struct ClientCounters {
  std::uint64_t connects{0};           // transport connections made
  std::uint64_t welcomes{0};
  std::uint64_t disconnects{0};
  std::uint64_t messages_received{0};  // handed to the sink
  std::uint64_t malformed{0};          // undecodable frames (dropped, logged)
  std::uint64_t wrong_direction{0};    // client->host types or unexpected handshake messages
  std::uint64_t messages_sent{0};
  std::uint64_t bytes_sent{0};
  std::uint64_t bytes_received{0};
  std::uint64_t send_dropped{0};       // send() while not connected
  std::uint64_t failed_attempts{0};    // attempts that ended without a Welcome (nor a Refuse)
  std::uint64_t turned_away{0};        // transient refusals (host full, too fast), each retried
  // CPU time the network thread has used (receive, decode, the sink's apply): what it takes
  // from a display thread and a CPU renderer sharing its core. -1 where not measurable.
  double thread_cpu_ms{-1.0};
  std::string last_rejection;          // also the host's reason after a Refuse
};

class NetClient {
 public:
  // Starts the service thread (it connects in the background; see status()).
  // `sink` must outlive the client.
  static Expected<std::unique_ptr<NetClient>> start(NetClientConfig config, ClientSink& sink);
  ~NetClient();  // polite disconnect, then stop
  NetClient(const NetClient&) = delete;
  NetClient& operator=(const NetClient&) = delete;

  // Encodes and queues a client->host message (HeadPose unreliable, the rest
  // reliable). Fails for a host->client type or a message the schema refuses; while
  // not connected the message is dropped and counted (pose/query state is resent by
  // the caller after the next Welcome).
  Status send(const wire::Message& m);
  // Sends raw bytes as one packet on `channel` (tests use it to inject malformed input).
  Status send_raw(std::vector<std::uint8_t> bytes, std::uint8_t channel);

  ClientStatus status() const;
  // Blocks until status() == `s` or the timeout passes.
  bool wait_for(ClientStatus s, std::chrono::milliseconds timeout) const;
  ClientCounters counters() const;

  // Stops the thread WITHOUT telling the host, as a crashed process would: the host
  // notices only through its peer timeout. For fault tests.
  void abandon();

 private:
  struct Impl;
  explicit NetClient(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss::net
