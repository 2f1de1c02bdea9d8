// NetClient: connect / Hello / receive loop on its own thread, with reconnects.
#include "gauss/net/client.h"

#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "enet_runtime.h"
#include "gauss/engine/log_text.h"
#include "gauss/net/auth.h"
#include "gauss/net/stream_cipher.h"
#include "packet_ref.h"

namespace gauss::net {

using Clock = std::chrono::steady_clock;

namespace {
struct ClientOutgoing {
  std::uint8_t channel{0};
  bool reliable{true};
  detail::Frame frame;
};

// Encodes a client->host message for the outbox. Fails for a host->client type or a
// Hello (only the service sends one, once per connection) and for a message the
// schema refuses.
Expected<ClientOutgoing> outgoing(const wire::Message& m) {
  const msg::MessageType type = wire::type_of(m);
  if (msg::direction_of(type) != msg::Direction::ClientToHost || type == msg::MessageType::Hello)
    return Error{std::string("NetClient::send: ") + msg::to_string(type) + " is not a client message to send"};
  auto bytes = wire::encode(m);
  if (!bytes) return bytes.error();
  // A lost pose is replaced by the next one within ~100 ms; everything else must arrive.
  return ClientOutgoing{msg::channel_of(type), type != msg::MessageType::HeadPose,
                  std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes).value())};
}
}  // namespace

struct NetClient::Impl {
  NetClientConfig cfg;
  ClientSink* sink{nullptr};
  detail::EnetRef enet;
  ENetAddress server{};
  std::string endpoint;  // the server as HOST:PORT, for the log
  detail::Frame hello;  // encoded once in start(), sent on every connection
  std::thread thread;
  std::atomic<bool> stop{false};
  std::atomic<bool> abandoned{false};

  mutable std::mutex mu;  // status, outbox, counters
  mutable std::condition_variable cv;
  ClientStatus status{ClientStatus::Connecting};
  std::vector<ClientOutgoing> outbox;
  ClientCounters counters;
  // Network thread only: the last Welcome's host session and when the last welcomed
  // connection was lost (for the reconnect log line).
  std::optional<std::uint64_t> last_session;
  Clock::time_point last_lost{};
  // The connection's handshake (network thread): the keys once this client answered the
  // Challenge, whether the host then proved the secret too, and the sealed stream when the
  // Challenge asked for one (set once the host proved it).
  std::optional<SessionKeys> keys;
  bool encrypt{false};
  bool host_proved{false};
  std::unique_ptr<StreamCipher> sealer;  // client -> host
  std::unique_ptr<StreamCipher> opener;  // host -> client
  // This connection was refused for a reason that may pass (msg::refusal_is_transient).
  bool turned_away{false};

  ~Impl() {
    if (thread.joinable()) {
      stop = true;
      thread.join();
    }
  }

  void log(const std::string& line) const {
    if (cfg.log) cfg.log(line);
    else std::fprintf(stderr, "[gauss-net client %s] %s\n", cfg.name.c_str(), line.c_str());
  }

  void set_status(ClientStatus s) {
    {
      std::lock_guard lock(mu);
      status = s;
    }
    cv.notify_all();
  }

  void reject(const std::string& why, std::uint64_t ClientCounters::*counter) {
    std::uint64_t n = 0;
    {
      std::lock_guard lock(mu);
      n = ++(counters.*counter);
      counters.last_rejection = why;
    }
    if (n <= 8 || n % 100 == 0) log("rejected message: " + why);
  }

  void flush(ENetPeer* peer) {
    for (const auto& m : sink->take_outgoing()) {
      auto o = outgoing(m);
      if (!o) {
        log("dropping an outgoing " + std::string(msg::to_string(wire::type_of(m))) + ": " + o.message());
        std::lock_guard lock(mu);
        ++counters.send_dropped;
        continue;
      }
      std::lock_guard lock(mu);
      outbox.push_back(std::move(o).value());
    }
    std::vector<ClientOutgoing> out;
    {
      std::lock_guard lock(mu);
      out.swap(outbox);
    }
    for (auto& o : out) {
      if (sealer) o.frame = std::make_shared<const std::vector<std::uint8_t>>(sealer->seal(*o.frame));
      ENetPacket* p = detail::make_packet(o.frame, o.reliable, nullptr);
      const bool ok = p != nullptr && enet_peer_send(peer, o.channel, p) == 0;
      if (!ok && p != nullptr) enet_packet_destroy(p);
      std::lock_guard lock(mu);
      if (ok) {
        ++counters.messages_sent;
        counters.bytes_sent += o.frame->size();
      } else {
        ++counters.send_dropped;
      }
    }
  }

  void drop_outbox() {
    std::lock_guard lock(mu);
    counters.send_dropped += outbox.size();
    outbox.clear();
  }

  // Handles one received frame; returns false when the connection must end (refused).
  bool receive(ENetPeer* peer, const ENetPacket* packet, bool& welcomed, std::optional<msg::Welcome>& welcome_out) {
    {
      std::lock_guard lock(mu);
      counters.bytes_received += packet->dataLength;
    }
    std::span<const std::uint8_t> frame(packet->data, packet->dataLength);
    std::vector<std::uint8_t> opened;
    // On a sealed stream every frame is sealed, except a refusal before the Welcome (the
    // host refuses before it holds keys when the proof fails, and after the handshake
    // when the policy refuses before welcoming).
    const bool sealed = opener && looks_sealed(frame);
    if (sealed) {
      auto o = opener->open(frame);
      if (!o) {
        reject("sealed stream: " + o.message(), &ClientCounters::malformed);
        return true;
      }
      opened = std::move(o).value();
      frame = opened;
    }
    auto decoded = wire::decode(frame);
    if (!decoded.ok()) {
      reject("malformed: " + decoded.message(), &ClientCounters::malformed);
      return true;
    }
    wire::Message& m = decoded.value();
    const msg::MessageType type = wire::type_of(m);
    if (opener && !sealed && (welcomed || type != msg::MessageType::Refuse)) {
      reject(std::string("plain ") + msg::to_string(type) + " on a sealed stream", &ClientCounters::malformed);
      return true;
    }
    if (msg::direction_of(type) != msg::Direction::HostToClient) {
      reject(std::string("unexpected ") + msg::to_string(type) + " from the host", &ClientCounters::wrong_direction);
      return true;
    }
    if (auto* refuse = std::get_if<msg::Refuse>(&m)) {
      // The detail is the host's text, and the host may be anyone on the network: it
      // reaches logs, terminals and panels escaped (no line breaks, no terminal codes).
      refuse->detail = escape_for_log(refuse->detail, msg::kMaxReasonBytes);
      const std::string why = "refused by " + endpoint + ": " + refuse->detail;
      {
        std::lock_guard lock(mu);
        counters.last_rejection = why;
      }
      if (cfg.reconnect && !welcomed && msg::refusal_is_transient(refuse->reason)) {
        // The host cannot take this session now (full, or sessions opened too fast):
        // run() tries again later, backing off, and says so once. The sink hears nothing:
        // it was never welcomed on this connection.
        turned_away = true;
        return false;
      }
      log(why + "; not retrying");
      sink->on_refused(*refuse);
      set_status(ClientStatus::Refused);
      return false;
    }
    if (std::holds_alternative<msg::Challenge>(m)) {
      if (welcomed || keys) {
        // One answer per connection: each answer lets whoever sent the Challenge test one
        // guess of the secret (CPace's online guess), so a second one gets none.
        reject("unexpected Challenge", &ClientCounters::wrong_direction);
        return true;
      }
      // Nothing to prove with: end here, as a refusal, with the reason a user can act on.
      if (cfg.access_token.empty()) return end_handshake("the host requires an access token and none was given");
      auto answer = answer_challenge(cfg.access_token, frame, *hello);
      if (!answer) return end_handshake("cannot answer the host's challenge: " + answer.message());
      keys = answer->keys;
      encrypt = (std::get<msg::Challenge>(m).flags & msg::kChallengeEncrypt) != 0;
      auto bytes = wire::encode(answer->proof);
      if (bytes.ok())
        if (ENetPacket* p = detail::make_packet(std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes).value()),
                                                true, nullptr))
          if (enet_peer_send(peer, msg::kChannelModel, p) != 0) enet_packet_destroy(p);
      return true;
    }
    if (const auto* confirm = std::get_if<msg::AuthConfirm>(&m)) {
      if (!keys || host_proved) {
        reject("unexpected AuthConfirm", &ClientCounters::wrong_direction);
        return true;
      }
      if (!host_confirmed(*keys, *confirm))
        return end_handshake("the host could not prove it knows the access token (it may not be the host you meant)");
      host_proved = true;
      if (encrypt) {
        sealer = std::make_unique<StreamCipher>(keys->client_to_host, StreamDirection::ClientToHost);
        opener = std::make_unique<StreamCipher>(keys->host_to_client, StreamDirection::HostToClient);
      }
      keys.reset();
      return true;
    }
    // A client that holds a secret talks only to a host that proved it knows it too.
    if (!cfg.access_token.empty() && !host_proved)
      return end_handshake(std::string("the host sent ") + msg::to_string(type) +
                           " without proving it knows the access token (it may not be the host you meant, or "
                           "it runs without one)");
    if (auto* welcome = std::get_if<msg::Welcome>(&m)) {
      if (welcomed || welcome->protocol_version != msg::kProtocolVersion) {
        reject("unexpected Welcome", &ClientCounters::wrong_direction);
        return true;
      }
      welcomed = true;
      welcome_out = *welcome;
      log_welcome(*welcome);
      {
        std::lock_guard lock(mu);
        ++counters.welcomes;
      }
      sink->on_welcome(*welcome);
      set_status(ClientStatus::Connected);
      return true;
    }
    if (!welcomed) {
      reject(std::string(msg::to_string(type)) + " before Welcome", &ClientCounters::wrong_direction);
      return true;
    }
    {
      std::lock_guard lock(mu);
      ++counters.messages_received;
    }
    sink->on_message(std::move(m));
    return true;
  }

  // Ends this connection before its Welcome, as a refusal (no retry: the same host would
  // answer the same way), for a reason found here rather than sent by the host.
  bool end_handshake(const std::string& why) {
    msg::Refuse r{msg::RefuseReason::BadToken, msg::kProtocolVersion, why.substr(0, msg::kMaxReasonBytes)};
    log("ending the connection to " + endpoint + ": " + r.detail + "; not retrying");
    {
      std::lock_guard lock(mu);
      counters.last_rejection = r.detail;
    }
    sink->on_refused(r);
    set_status(ClientStatus::Refused);
    return false;
  }

  void log_welcome(const msg::Welcome& w) {
    char id[80];
    std::snprintf(id, sizeof id, "host session %016llx, client %u, %u slots",
                  static_cast<unsigned long long>(w.session_id), w.client_id, w.slot_capacity);
    std::string line = "connected to " + endpoint + " (" + id + ")";
    if (last_session) {
      char after[48];
      std::snprintf(after, sizeof after, " after %.1f s",
                    std::chrono::duration<double>(Clock::now() - last_lost).count());
      line = "reconnected to " + endpoint + after + " (" + id +
             (*last_session == w.session_id ? ", same host session" : ", the host restarted") + "); resynchronising";
    }
    last_session = w.session_id;
    log(line);
  }

  // How one attempt ended.
  enum class Outcome { Unreachable, ClosedBeforeWelcome, TurnedAway, Lost, Refused, Stopped };

  // One connection attempt and its whole life. Returns when it ends; `welcome` gets the
  // connection's Welcome when there was one.
  Outcome session(ENetHost* host, std::optional<msg::Welcome>& welcome) {
    keys.reset();  // keys belong to one connection
    encrypt = false;
    host_proved = false;
    turned_away = false;
    sealer.reset();
    opener.reset();
    ENetPeer* peer = enet_host_connect(host, &server, msg::kChannelCount, 0);
    if (peer == nullptr) {
      log("cannot start a connection to " + endpoint + " (ENet has no free peer)");
      return Outcome::Unreachable;
    }
    enet_peer_timeout(peer, 0, static_cast<enet_uint32>(cfg.peer_timeout_min.count()),
                      static_cast<enet_uint32>(cfg.peer_timeout_max.count()));
    ENetEvent ev;
    bool connected = false, welcomed = false, refused = false;
    const auto deadline = Clock::now() + cfg.connect_timeout;
    while (!stop.load() && !connected && Clock::now() < deadline) {
      if (enet_host_service(host, &ev, 5) > 0 && ev.type == ENET_EVENT_TYPE_CONNECT) connected = true;
    }
    if (!connected) {
      enet_peer_reset(peer);
      return stop.load() ? Outcome::Stopped : Outcome::Unreachable;
    }
    {
      std::lock_guard lock(mu);
      ++counters.connects;
    }
    if (ENetPacket* p = detail::make_packet(hello, true, nullptr)) {
      if (enet_peer_send(peer, msg::kChannelModel, p) != 0) enet_packet_destroy(p);
    }
    bool alive = true;
    while (alive && !stop.load()) {
      if (welcomed) flush(peer);
      int r = enet_host_service(host, &ev, 2);
      while (r > 0 && alive && !refused) {
        if (ev.type == ENET_EVENT_TYPE_RECEIVE) {
          if (!receive(peer, ev.packet, welcomed, welcome)) refused = true;
          enet_packet_destroy(ev.packet);
        } else if (ev.type == ENET_EVENT_TYPE_DISCONNECT) {
          alive = false;
        }
        // Nothing after a refusal is handled: it would speak over the reason given.
        if (alive && !refused) r = enet_host_service(host, &ev, 0);
      }
      if (refused) alive = false;  // nothing more to say
    }
    if (abandoned.load()) {
      enet_peer_reset(peer);  // no goodbye: the host finds out by timeout
    } else if (alive || refused) {
      // Ours to end (stop()), or refused: let the host's disconnect arrive (it closes once
      // its Refuse is delivered) or give up quickly, and free the one peer for the next
      // attempt.
      enet_peer_disconnect(peer, 0);
      const auto until = Clock::now() + std::chrono::milliseconds(300);
      while (Clock::now() < until)
        if (enet_host_service(host, &ev, 10) > 0 && ev.type == ENET_EVENT_TYPE_DISCONNECT) break;
      enet_peer_reset(peer);
    }
    if (welcomed) {
      std::lock_guard lock(mu);
      ++counters.disconnects;
    }
    if (turned_away) return Outcome::TurnedAway;
    if (welcomed || refused) sink->on_disconnected(refused ? "refused" : "connection closed");
    if (refused) return Outcome::Refused;
    if (alive) return Outcome::Stopped;  // we ended it: stop() or abandon()
    return welcomed ? Outcome::Lost : Outcome::ClosedBeforeWelcome;
  }

  static std::string seconds(std::chrono::milliseconds ms) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2g s", static_cast<double>(ms.count()) / 1000.0);
    return buf;
  }

  // Attempts until stopped or refused. Logs once per change of state: an unreachable
  // host is reported by its first failed attempt, not by every retry.
  void run(ENetHost* host) {
    std::chrono::milliseconds delay = cfg.reconnect_delay;
    bool reported_unreachable = false;
    std::string reported_refusal;  // the transient refusal last logged
    while (!stop.load()) {
      std::optional<msg::Welcome> welcome;
      const Outcome outcome = session(host, welcome);
      drop_outbox();
      if (welcome) {
        delay = cfg.reconnect_delay;  // a Welcome resets the backoff
        reported_unreachable = false;
        reported_refusal.clear();
      }
      if (outcome == Outcome::Refused || outcome == Outcome::Stopped) break;
      if (outcome == Outcome::TurnedAway) {
        std::string why;
        {
          std::lock_guard lock(mu);
          ++counters.turned_away;
          why = counters.last_rejection;
        }
        if (why != reported_refusal) {
          reported_refusal = why;
          log(why + "; retrying, up to " + seconds(cfg.reconnect_delay_max) + " apart");
        }
      } else if (outcome == Outcome::Lost) {
        log("lost the connection to " + endpoint + "; " +
            (cfg.reconnect ? "reconnecting, showing the last state meanwhile" : "not reconnecting"));
        last_lost = Clock::now();
      } else {
        {
          std::lock_guard lock(mu);
          ++counters.failed_attempts;
        }
        if (!reported_unreachable) {
          reported_unreachable = true;
          if (outcome == Outcome::Unreachable)
            log("cannot reach " + endpoint + " (no answer within " + seconds(cfg.connect_timeout) + ")" +
                (cfg.reconnect ? "; retrying every ~" + seconds(cfg.connect_timeout + cfg.reconnect_delay_max) +
                                     " until it answers"
                               : "; giving up"));
          else
            log("the connection to " + endpoint + " closed before the host's Welcome" +
                (cfg.reconnect ? "; retrying" : "; giving up"));
        }
      }
      if (!cfg.reconnect || stop.load()) break;
      set_status(ClientStatus::Connecting);
      const auto until = Clock::now() + delay;
      while (!stop.load() && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      if (!welcome) delay = std::min(delay * 2, std::max(cfg.reconnect_delay, cfg.reconnect_delay_max));
    }
    enet_host_destroy(host);
    std::lock_guard lock(mu);
    if (status != ClientStatus::Refused) status = ClientStatus::Stopped;
    cv.notify_all();
  }
};

NetClient::NetClient(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NetClient::~NetClient() = default;

Expected<std::unique_ptr<NetClient>> NetClient::start(NetClientConfig config, ClientSink& sink) {
  msg::Hello hello;
  hello.slot_capacity = config.slot_capacity;
  // The token never crosses the wire: the host challenges, receive() answers.
  hello.client_name = config.name;
  auto bytes = wire::encode(hello);
  if (!bytes) return Error{"ClientConfig: " + bytes.message()};
  auto impl = std::make_unique<Impl>();
  impl->cfg = std::move(config);
  impl->hello = std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes).value());
  impl->sink = &sink;
  if (!impl->cfg.access_token.empty()) {
    if (impl->cfg.access_token.size() > msg::kMaxTokenBytes)
      return Error{"ClientConfig: access token longer than " + std::to_string(msg::kMaxTokenBytes) + " bytes"};
    if (auto s = auth_init(); !s) return s.error();
  }
  if (auto s = impl->enet.acquire(); !s) return s.error();
  auto addr = detail::resolve(impl->cfg.server);
  if (!addr) return addr.error();
  impl->server = addr.value();
  impl->endpoint = to_string(impl->cfg.server);
  auto host = detail::create_host(nullptr, 1, 2 * msg::kMaxMessageBytes);
  if (!host) return host.error();
  Impl* raw = impl.get();
  ENetHost* h = host.value();
  impl->thread = std::thread([raw, h] { raw->run(h); });
  return std::unique_ptr<NetClient>(new NetClient(std::move(impl)));
}

Status NetClient::send(const wire::Message& m) {
  auto o = outgoing(m);
  if (!o) return o.error();
  std::lock_guard lock(impl_->mu);
  if (impl_->status != ClientStatus::Connected) {
    ++impl_->counters.send_dropped;
    return Ok{};
  }
  impl_->outbox.push_back(std::move(o).value());
  return Ok{};
}

Status NetClient::send_raw(std::vector<std::uint8_t> bytes, std::uint8_t channel) {
  if (channel >= msg::kChannelCount) return Error{"NetClient::send_raw: channel " + std::to_string(channel) + " does not exist"};
  if (bytes.empty()) return Error{"NetClient::send_raw: empty packet"};
  std::lock_guard lock(impl_->mu);
  impl_->outbox.push_back(ClientOutgoing{channel, true, std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes))});
  return Ok{};
}

ClientStatus NetClient::status() const {
  std::lock_guard lock(impl_->mu);
  return impl_->status;
}

bool NetClient::wait_for(ClientStatus s, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(impl_->mu);
  return impl_->cv.wait_for(lock, timeout, [&] { return impl_->status == s; });
}

ClientCounters NetClient::counters() const {
  ClientCounters c;
  {
    std::lock_guard lock(impl_->mu);
    c = impl_->counters;
  }
  clockid_t clock{};
  timespec ts{};
  if (impl_->thread.joinable() && pthread_getcpuclockid(impl_->thread.native_handle(), &clock) == 0 &&
      clock_gettime(clock, &ts) == 0)
    c.thread_cpu_ms = static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
  return c;
}

void NetClient::abandon() {
  impl_->abandoned = true;
  impl_->stop = true;
  if (impl_->thread.joinable()) impl_->thread.join();
}

}  // namespace gauss::net
