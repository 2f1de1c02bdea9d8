// NetHost: ENet service thread, handshake and per-connection input hygiene.
#include "gauss/net/host.h"

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <random>
#include <thread>
#include <unordered_map>

#include "enet_runtime.h"
#include "gauss/engine/log_text.h"
#include "gauss/net/auth.h"
#include "gauss/net/stream_cipher.h"
#include "guard_summary.h"
#include "packet_ref.h"
#include "pending_peers.h"

namespace gauss::net {

using Clock = std::chrono::steady_clock;

namespace {

struct HostOutgoing {
  std::uint32_t client{0};
  msg::MessageType type{msg::MessageType::Welcome};
  detail::Frame frame;     // null: a disconnect request
};

struct PeerState {
  bool welcomed{false};
  bool closing{false};     // refused or kicked: further input is ignored
  bool hostile{false};     // refused at the handshake or kicked: dropped if it lingers
  bool counted{false};     // holds one of its address's client slots (AdmissionGuard)
  std::uint32_t client{0};
  AdmissionGuard::Address address{0};
  Clock::time_point connected_at{};
  Clock::time_point closing_since{};
  Clock::time_point waiting_since{};  // input held undelivered since (stall check); epoch: none
  double tokens{0.0};      // query bucket
  Clock::time_point refilled{};
  double message_tokens{0.0};  // message bucket
  Clock::time_point message_refilled{};
  std::uint32_t rejected{0};
  detail::ByteCounter pending;
  // Token authentication: the Hello waits here while its Challenge is answered; the
  // handshake holds the CPace scalars until the proof arrives.
  bool challenged{false};
  std::unique_ptr<HostHandshake> pake;
  msg::Hello hello{};
  // A sealed stream (encrypt_stream): set when the proof passed.
  std::shared_ptr<StreamCipher> sealer;  // host -> client
  std::shared_ptr<StreamCipher> opener;  // client -> host
};

// Only the first few rejections per connection are logged in full; after that one
// line per 100 keeps a flood from flooding the log too (the counters keep the rest).
constexpr std::uint32_t kLoggedRejections = 8;

// While peer slots run short, a connection that has sent no Hello this long after ENet's
// handshake (or a connect request unacknowledged this long) may be dropped early: a
// client acknowledges, then sends its Hello, each within a round trip.
constexpr auto kSilentGrace = std::chrono::milliseconds(500);

// Free peer slots kept in reserve (at least this share of them) by dropping the oldest
// half-open and silent connections early, so the next connect finds one.
constexpr std::size_t kReserveDivisor = 8;

// "1 client", "4 clients": a limit as a refusal states it.
std::string clients_text(std::size_t n) { return std::to_string(n) + (n == 1 ? " client" : " clients"); }

}  // namespace

struct NetHost::Impl {
  NetHostConfig cfg;
  detail::EnetRef enet;
  ENetHost* host{nullptr};
  std::uint64_t session{0};
  std::thread thread;
  std::atomic<bool> stop{false};

  mutable std::mutex mu;  // outbox, events, counters, pending, client_count
  std::condition_variable cv;
  std::vector<HostOutgoing> outbox;
  std::deque<HostEvent> events;
  HostCounters counters;
  std::unordered_map<std::uint32_t, detail::ByteCounter> pending;  // welcomed clients
  std::unordered_map<std::uint32_t, std::shared_ptr<StreamCipher>> sealers;  // welcomed clients with a sealed stream

  // Service-thread only.
  std::unordered_map<ENetPeer*, PeerState> peers;
  std::unordered_map<std::uint32_t, ENetPeer*> clients;
  std::uint32_t next_client{1};
  std::unique_ptr<AdmissionGuard> admission;
  detail::PendingPeers pending_peers;
  Clock::time_point next_summary{};
  Clock::time_point last_summary{};
  HostCounters summarized;  // the counts at the last summary line

  ~Impl() {
    if (thread.joinable()) {
      stop = true;
      thread.join();
    }
    if (host != nullptr) enet_host_destroy(host);
  }

  void log(const std::string& line) const {
    if (cfg.log) cfg.log(line);
    else std::fprintf(stderr, "[gauss-net host] %s\n", line.c_str());
  }

  void push_event(HostEvent e) {
    {
      std::lock_guard lock(mu);
      if (events.size() >= cfg.max_queued_events) {
        ++counters.events_dropped;
        return;
      }
      events.push_back(std::move(e));
    }
    cv.notify_all();
  }

  // Sends `m` now, sealed once the peer is welcomed on a sealed stream (a refusal before
  // that goes plain: the client may not hold the keys).
  void send_now(ENetPeer* peer, const PeerState& ps, const wire::Message& m) {
    auto bytes = wire::encode(m);
    if (!bytes.ok()) {
      log("internal: cannot encode " + std::string(msg::to_string(wire::type_of(m))) + ": " + bytes.message());
      return;
    }
    send_frame_now(peer, ps, wire::type_of(m), std::move(bytes).value());
  }

  // The same for a frame already encoded (the Challenge: its exact bytes are the
  // handshake's transcript).
  void send_frame_now(ENetPeer* peer, const PeerState& ps, msg::MessageType type, std::vector<std::uint8_t> bytes) {
    if (ps.welcomed && ps.sealer) bytes = ps.sealer->seal(bytes);
    auto frame = std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes));
    detail::HostSendLimit sending(host);
    if (ENetPacket* p = detail::make_packet(frame, true, nullptr)) {
      if (enet_peer_send(peer, msg::channel_of(type), p) != 0) enet_packet_destroy(p);
      std::lock_guard lock(mu);
      ++counters.messages_sent;
      counters.bytes_sent += frame->size();
    }
  }

  void refuse(ENetPeer* peer, PeerState& ps, msg::RefuseReason reason, const std::string& detail,
              std::uint64_t HostCounters::*counter) {
    {
      std::lock_guard lock(mu);
      ++(counters.*counter);
      counters.last_rejection = "refused: " + detail;
    }
    // Counted, not logged: the summary line reports refusals (see summarize()).
    msg::Refuse r{reason, msg::kProtocolVersion, detail.substr(0, msg::kMaxReasonBytes)};
    send_now(peer, ps, r);
    close_hostile(peer, ps);
  }

  void reject(ENetPeer* peer, PeerState& ps, const std::string& why, std::uint64_t HostCounters::*counter) {
    ++ps.rejected;
    {
      std::lock_guard lock(mu);
      ++(counters.*counter);
      counters.last_rejection = why;
    }
    if (ps.rejected <= kLoggedRejections || ps.rejected % 100 == 0)
      log("client " + std::to_string(ps.client) + ": rejected message #" + std::to_string(ps.rejected) + ": " + why);
    if (ps.rejected > cfg.max_rejected_per_client && !ps.closing) {
      log("client " + std::to_string(ps.client) + ": disconnected after " + std::to_string(ps.rejected) +
          " rejected messages");
      {
        std::lock_guard lock(mu);
        ++counters.kicked;
      }
      close_hostile(peer, ps);
    }
  }

  // Closes after what is queued is delivered, but only for so long: a peer that does not
  // take its Refuse (or the kick) and leave is dropped (tick()).
  void close_hostile(ENetPeer* peer, PeerState& ps) {
    ps.closing = true;
    ps.hostile = true;
    ps.closing_since = Clock::now();
    enet_peer_disconnect_later(peer, 0);
  }

  void handshake(ENetPeer* peer, PeerState& ps, Expected<wire::Message> decoded,
                 std::span<const std::uint8_t> frame) {
    if (!decoded.ok())
      return refuse(peer, ps, msg::RefuseReason::Malformed, "bad first message: " + decoded.message(),
                    &HostCounters::refused_malformed);
    auto* hello = std::get_if<msg::Hello>(&decoded.value());
    if (hello == nullptr)
      return refuse(peer, ps, msg::RefuseReason::Malformed,
                    std::string("first message must be Hello, got ") + msg::to_string(wire::type_of(decoded.value())),
                    &HostCounters::refused_malformed);
    if (hello->protocol_version != msg::kProtocolVersion)
      return refuse(peer, ps, msg::RefuseReason::VersionMismatch,
                    "protocol version " + std::to_string(hello->protocol_version) + ", host speaks " +
                        std::to_string(msg::kProtocolVersion),
                    &HostCounters::refused_version);
    // The token never travels: a Hello carrying one is refused (whoever sent it has
    // already exposed it; the host does not even compare it).
    if (!hello->access_token.empty())
      return refuse(peer, ps, msg::RefuseReason::Malformed,
                    "a Hello must not carry the access token over the network (the host sends a challenge)",
                    &HostCounters::refused_malformed);
    if (auth_required()) {
      // Online guessing costs time: an address waits after each wrong proof (doubling),
      // and the host checks a bounded number of proofs per second whoever sends them.
      const auto now = Clock::now();
      if (auto wait = admission->auth_blocked(ps.address, now)) {
        const auto s = std::chrono::duration_cast<std::chrono::seconds>(*wait).count() + 1;
        return refuse(peer, ps, msg::RefuseReason::BadToken,
                      "authentication failed recently from this address; retry in " + std::to_string(s) + " s",
                      &HostCounters::refused_backoff);
      }
      if (!admission->take_proof(now))
        return refuse(peer, ps, msg::RefuseReason::HostFull, "too many authentication attempts on this host; retry shortly",
                      &HostCounters::refused_proof_rate);
      // Nothing else about this Hello is judged before the peer proved the token, so a
      // peer without it learns nothing but why its proof failed. The Challenge carries one
      // CPace message per secret (the token, a pairing code), with the Hello as CI.
      ps.challenged = true;
      ps.pake = std::make_unique<HostHandshake>(AuthSecrets{cfg.access_token, cfg.pairing_code}, frame,
                                                cfg.encrypt_stream ? msg::kChallengeEncrypt : std::uint8_t{0});
      ps.hello = *hello;
      send_frame_now(peer, ps, msg::MessageType::Challenge, ps.pake->challenge_frame());
      return;
    }
    admit(peer, ps, *hello);
  }

  bool auth_required() const { return !cfg.access_token.empty() || !cfg.pairing_code.empty(); }

  // The answer to this connection's Challenge. Anything but a proof whose tag matches is
  // refused as "authentication failed: <why>", counted as refused_token and as a wrong
  // guess of its address (the backoff): a malformed proof, a CPace point that does not
  // decode or is the identity, a wrong secret. The why names what was wrong with the
  // proof, never anything about the secret.
  void authenticate(ENetPeer* peer, PeerState& ps, Expected<wire::Message> decoded) {
    Expected<SessionKeys> keys = Error{"no proof"};
    if (!decoded.ok()) keys = Error{decoded.message()};
    else if (const auto* proof = std::get_if<msg::AuthProof>(&decoded.value())) keys = ps.pake->verify(*proof);
    else keys = Error{std::string("expected AuthProof, got ") + msg::to_string(wire::type_of(decoded.value()))};
    if (!keys) {
      ps.pake.reset();
      admission->auth_failed(ps.address, Clock::now());
      return refuse(peer, ps, msg::RefuseReason::BadToken, "authentication failed: " + keys.message(),
                    &HostCounters::refused_token);
    }
    admission->auth_passed(ps.address);
    ps.challenged = false;
    if (ps.pake->challenge().flags & msg::kChallengeEncrypt) {
      ps.sealer = std::make_shared<StreamCipher>(keys->host_to_client, StreamDirection::HostToClient);
      ps.opener = std::make_shared<StreamCipher>(keys->client_to_host, StreamDirection::ClientToHost);
    }
    ps.pake.reset();  // the scalars go: nothing left here opens this session's stream later
    // The host proves the secret in turn, before the policy's Welcome (or a Refuse):
    // plain, as the client opens sealed frames only once it has checked this.
    send_now(peer, ps, msg::AuthConfirm{keys->host_tag});
    admit(peer, ps, ps.hello);
  }

  // A Hello that passed version (and token): capacity and room, then Connected.
  void admit(ENetPeer* peer, PeerState& ps, const msg::Hello& hello_in) {
    const msg::Hello* hello = &hello_in;
    if (hello->slot_capacity > cfg.max_slot_capacity)
      return refuse(peer, ps, msg::RefuseReason::BadCapacity,
                    "slot capacity " + std::to_string(hello->slot_capacity) + " above this host's limit " +
                        std::to_string(cfg.max_slot_capacity),
                    &HostCounters::refused_capacity);
    if (clients.size() >= cfg.max_clients)
      return refuse(peer, ps, msg::RefuseReason::HostFull,
                    "host full (" + clients_text(cfg.max_clients) + ")", &HostCounters::refused_full);
    // A session costs the host its first scene, surface and resync: per address, a
    // bounded number at once and a bounded rate of new ones.
    switch (admission->open_session(ps.address, Clock::now())) {
      case AdmissionGuard::Open::Ok:
        ps.counted = true;
        break;
      case AdmissionGuard::Open::AddressFull:
        return refuse(peer, ps, msg::RefuseReason::HostFull,
                      "host full for this address (" + clients_text(cfg.admission.max_clients_per_address) + ")",
                      &HostCounters::refused_address_full);
      case AdmissionGuard::Open::RateLimited:
        return refuse(peer, ps, msg::RefuseReason::HostFull,
                      "too many sessions opened from this address; retry in a few seconds",
                      &HostCounters::refused_session_rate);
    }

    ps.welcomed = true;
    ps.client = next_client++;
    ps.tokens = cfg.query_burst;
    ps.refilled = Clock::now();
    ps.message_tokens = cfg.message_burst;
    ps.message_refilled = ps.refilled;
    ps.pending = std::make_shared<std::atomic<std::int64_t>>(0);
    clients[ps.client] = peer;
    {
      std::lock_guard lock(mu);
      ++counters.accepted;
      pending[ps.client] = ps.pending;
      if (ps.sealer) sealers[ps.client] = ps.sealer;
    }
    // The policy answers with Welcome (or Refuse) through send(); the model channel
    // is ordered, so whatever it queues after the Welcome arrives after it.
    HostEvent e;
    e.kind = HostEventKind::Connected;
    e.client = ps.client;
    e.hello = *hello;
    log("client " + std::to_string(ps.client) + " '" + escape_for_log(hello->client_name) + "' connected, capacity " +
        std::to_string(hello->slot_capacity));
    push_event(std::move(e));
  }

  // One token from a bucket of `burst` refilled at `rate` per second.
  static bool take_token(double& tokens, Clock::time_point& refilled, double rate, double burst) {
    const auto now = Clock::now();
    const double dt = std::chrono::duration<double>(now - refilled).count();
    refilled = now;
    tokens = std::min(burst, tokens + dt * rate);
    if (tokens < 1.0) return false;
    tokens -= 1.0;
    return true;
  }
  bool take_query_token(PeerState& ps) {
    return take_token(ps.tokens, ps.refilled, cfg.query_rate_hz, cfg.query_burst);
  }

  void receive(ENetPeer* peer, const ENetPacket* packet) {
    auto it = peers.find(peer);
    if (it == peers.end()) return;
    PeerState& ps = it->second;
    {
      std::lock_guard lock(mu);
      counters.bytes_received += packet->dataLength;
    }
    // Input is moving: data still waiting behind it (a fragment, a retransmission on a
    // lossy link) is not a stall. Only waiting with nothing delivered is.
    ps.waiting_since = {};
    if (ps.closing) return;
    std::span<const std::uint8_t> frame(packet->data, packet->dataLength);
    std::vector<std::uint8_t> opened;
    if (ps.welcomed && ps.opener) {
      auto o = ps.opener->open(frame);
      if (!o) return reject(peer, ps, "sealed stream: " + o.message(), &HostCounters::malformed);
      opened = std::move(o).value();
      frame = opened;
    }
    auto decoded = wire::decode(frame);
    if (!ps.welcomed && ps.challenged) return authenticate(peer, ps, std::move(decoded));
    if (!ps.welcomed) return handshake(peer, ps, std::move(decoded), frame);
    if (!decoded.ok()) return reject(peer, ps, "malformed: " + decoded.message(), &HostCounters::malformed);
    const msg::MessageType type = wire::type_of(decoded.value());
    if (msg::direction_of(type) != msg::Direction::ClientToHost || type == msg::MessageType::Hello ||
        type == msg::MessageType::AuthProof)
      return reject(peer, ps, std::string("unexpected ") + msg::to_string(type) + " from a client",
                    &HostCounters::wrong_direction);
    if (!take_token(ps.message_tokens, ps.message_refilled, cfg.message_rate_hz, cfg.message_burst))
      return reject(peer, ps, std::string(msg::to_string(type)) + " over the message rate limit",
                    &HostCounters::message_flood);
    if (type == msg::MessageType::Query && !take_query_token(ps)) {
      const auto& q = std::get<msg::Query>(decoded.value());
      reject(peer, ps, "query " + std::to_string(q.query_id) + " over the rate limit", &HostCounters::query_flood);
      msg::QueryReply reply;
      reply.query_id = q.query_id;
      reply.status = msg::QueryStatus::Rejected;
      reply.reason = "query rate limit: " + std::to_string(cfg.query_rate_hz) + " per second";
      if (!ps.closing) send_now(peer, ps, reply);
      return;
    }
    {
      std::lock_guard lock(mu);
      ++counters.messages_received;
    }
    HostEvent e;
    e.kind = HostEventKind::Message;
    e.client = ps.client;
    e.message = std::move(decoded).value();
    push_event(std::move(e));
  }

  void disconnected(ENetPeer* peer) {
    auto it = peers.find(peer);
    if (it == peers.end()) return;
    if (it->second.counted) admission->client_closed(it->second.address);
    if (it->second.welcomed) {
      const std::uint32_t id = it->second.client;
      clients.erase(id);
      {
        std::lock_guard lock(mu);
        ++counters.disconnects;
        pending.erase(id);
        sealers.erase(id);
      }
      log("client " + std::to_string(id) + " disconnected");
      HostEvent e;
      e.kind = HostEventKind::Disconnected;
      e.client = id;
      e.reason = "connection closed or timed out";
      push_event(std::move(e));
    }
    peers.erase(it);
  }

  void flush() {
    std::vector<HostOutgoing> out;
    {
      std::lock_guard lock(mu);
      out.swap(outbox);
    }
    detail::HostSendLimit sending(host);
    for (auto& o : out) {
      auto it = clients.find(o.client);
      if (it == clients.end()) {
        std::lock_guard lock(mu);
        ++counters.send_dropped;
        continue;
      }
      ENetPeer* peer = it->second;
      PeerState& ps = peers[peer];
      if (!o.frame) {
        ps.closing = true;
        enet_peer_disconnect_later(peer, 0);
        continue;
      }
      if (ps.closing) {
        std::lock_guard lock(mu);
        ++counters.send_dropped;
        continue;
      }
      ENetPacket* p = detail::make_packet(o.frame, true, ps.pending);
      bool ok = p != nullptr && enet_peer_send(peer, msg::channel_of(o.type), p) == 0;
      if (!ok && p != nullptr) enet_packet_destroy(p);
      if (o.type == msg::MessageType::Refuse) {
        // The policy refused the Hello: close once the Refuse is delivered.
        ps.closing = true;
        enet_peer_disconnect_later(peer, 0);
      }
      std::lock_guard lock(mu);
      if (o.type == msg::MessageType::Refuse) ++counters.refused_by_policy;
      if (ok) {
        ++counters.messages_sent;
        counters.bytes_sent += o.frame->size();
      } else {
        ++counters.send_dropped;
      }
    }
  }

  // Drops a peer now, without waiting for it to acknowledge (a hostile one never
  // would): ENet sends a disconnect and frees the slot; no DISCONNECT event follows, so
  // the bookkeeping runs here.
  void drop_now(ENetPeer* peer) {
    enet_peer_disconnect_now(peer, 0);
    disconnected(peer);
  }

  // Once per service pass: the admission limits that run on time (admission.h).
  void tick() {
    const auto now = Clock::now();
    const auto& ac = cfg.admission;
    const std::size_t reserve = std::max<std::size_t>(2, host->peerCount / kReserveDivisor);
    const auto sweep = pending_peers.sweep(host, now, ac.pending_timeout);
    std::uint64_t handshake_timeouts = 0, refusals_dropped = 0, stalled = 0, evicted = 0, pending_evicted = 0;
    std::vector<ENetPeer*> drop;
    std::vector<std::pair<Clock::time_point, ENetPeer*>> silent;  // candidates to drop early
    for (auto& [peer, ps] : peers) {
      if (ps.closing) {
        // Refused or kicked and still here after its grace: it is not leaving.
        if (ps.hostile && now - ps.closing_since >= ac.pending_timeout) {
          drop.push_back(peer);
          ++refusals_dropped;
        }
        continue;
      }
      if (!ps.welcomed) {
        if (now - ps.connected_at >= cfg.handshake_timeout) {
          drop.push_back(peer);
          ++handshake_timeouts;
        } else if (!ps.challenged && now - ps.connected_at >= kSilentGrace) {
          silent.emplace_back(ps.connected_at, peer);
        }
        continue;
      }
      // A reliable channel held back by a gap the peer never fills keeps its input
      // waiting in ENet: nothing reaches the rejection count, so it is timed here, from
      // the last delivery (receive() restarts it) while data waits.
      if (peer->totalWaitingData == 0) {
        ps.waiting_since = {};
      } else if (ps.waiting_since == Clock::time_point{}) {
        ps.waiting_since = now;
      } else if (now - ps.waiting_since >= ac.stall_timeout) {
        log("client " + std::to_string(ps.client) + ": disconnected, its input stalled for " +
            std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(now - ps.waiting_since).count()) +
            " ms");
        drop.push_back(peer);
        ++stalled;
      }
    }
    // Short of slots: silent connections go first (they had their round trip to send a
    // Hello), then connect requests unacknowledged past the same grace.
    std::size_t free = sweep.free + drop.size();
    if (free < reserve && !silent.empty()) {
      std::sort(silent.begin(), silent.end());
      for (const auto& entry : silent) {
        if (free >= reserve) break;
        drop.push_back(entry.second);
        ++free;
        ++evicted;
      }
    }
    if (free < reserve) pending_evicted = pending_peers.evict_oldest(host, now, kSilentGrace, reserve - free);
    if (sweep.timed_out + pending_evicted + handshake_timeouts + refusals_dropped + stalled + evicted > 0) {
      std::lock_guard lock(mu);
      counters.pending_timeouts += sweep.timed_out;
      counters.pending_evicted += pending_evicted;
      counters.handshake_timeouts += handshake_timeouts;
      counters.handshake_evicted += evicted;
      counters.refusals_dropped += refusals_dropped;
      counters.stalled += stalled;
      counters.kicked += stalled;
      if (handshake_timeouts + evicted > 0) counters.last_rejection = "no Hello within the handshake timeout";
      if (stalled > 0) counters.last_rejection = "input stalled past the stall timeout";
    }
    for (ENetPeer* peer : drop) drop_now(peer);
    if (now >= next_summary) summarize(now);
  }

  // One line with what changed since the last one (guard_summary.h); nothing when quiet.
  void summarize(Clock::time_point now) {
    HostCounters c;
    {
      std::lock_guard lock(mu);
      c = counters;
    }
    const std::string line =
        detail::guard_summary(c, summarized, std::chrono::duration<double>(now - last_summary).count());
    if (!line.empty()) {
      log(line);
      ++c.summaries;
      std::lock_guard lock(mu);
      ++counters.summaries;
    }
    summarized = c;
    last_summary = now;
    next_summary = now + cfg.admission.summary_interval;
  }

  void handle(const ENetEvent& ev) {
    switch (ev.type) {
      case ENET_EVENT_TYPE_CONNECT: {
        PeerState ps;
        ps.connected_at = Clock::now();
        ps.address = ev.peer->address.host;
        peers[ev.peer] = std::move(ps);
        enet_peer_timeout(ev.peer, 0, static_cast<enet_uint32>(cfg.peer_timeout_min.count()),
                          static_cast<enet_uint32>(cfg.peer_timeout_max.count()));
        std::lock_guard lock(mu);
        ++counters.connections;
        break;
      }
      case ENET_EVENT_TYPE_RECEIVE:
        receive(ev.peer, ev.packet);
        enet_packet_destroy(ev.packet);
        break;
      case ENET_EVENT_TYPE_DISCONNECT:
        disconnected(ev.peer);
        break;
      case ENET_EVENT_TYPE_NONE:
        break;
    }
  }

  void run() {
    while (!stop.load()) {
      flush();
      ENetEvent ev;
      // A short wait bounds the latency of send() (the outbox is flushed between waits).
      int r = enet_host_service(host, &ev, 2);
      while (r > 0) {
        handle(ev);
        r = enet_host_service(host, &ev, 0);
      }
      tick();
    }
    summarize(Clock::now());  // what the last interval saw is not lost at shutdown
    flush();
    for (auto& [peer, ps] : peers) enet_peer_disconnect_later(peer, 0);
    // Give clients a moment to hear the disconnect; a client that does not answer
    // times out on its side.
    const auto until = Clock::now() + std::chrono::milliseconds(300);
    ENetEvent ev;
    while (!peers.empty() && Clock::now() < until)
      if (enet_host_service(host, &ev, 10) > 0) handle(ev);
  }
};

NetHost::NetHost(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

NetHost::~NetHost() = default;

Expected<std::unique_ptr<NetHost>> NetHost::start(NetHostConfig config) {
  // ENet allows 4095 peers: max_clients plus the spare slots for connections still in
  // the handshake.
  if (config.max_clients == 0 || config.max_clients > 4000)
    return Error{"NetHostConfig: max_clients " + std::to_string(config.max_clients) + " outside 1..4000"};
  if (auto e = validate(config.admission); !e.empty()) return Error{"NetHostConfig: admission: " + e};
  if (config.max_clients + config.admission.spare_peers > ENET_PROTOCOL_MAXIMUM_PEER_ID)
    return Error{"NetHostConfig: max_clients + admission.spare_peers above ENet's " +
                 std::to_string(ENET_PROTOCOL_MAXIMUM_PEER_ID) + " peers"};
  if (config.handshake_timeout.count() <= 0) return Error{"NetHostConfig: handshake_timeout must be positive"};
  if (config.max_slot_capacity == 0 || config.max_slot_capacity > gauss::kMaxSlotCapacity)
    return Error{"NetHostConfig: max_slot_capacity outside [1, " + std::to_string(gauss::kMaxSlotCapacity) + "]"};
  if (!(config.query_rate_hz > 0.0) || !(config.query_burst >= 1.0))
    return Error{"NetHostConfig: query_rate_hz must be > 0 and query_burst >= 1"};
  if (!(config.message_rate_hz > 0.0) || !(config.message_burst >= 1.0))
    return Error{"NetHostConfig: message_rate_hz must be > 0 and message_burst >= 1"};
  if (config.access_token.size() > msg::kMaxTokenBytes)
    return Error{"NetHostConfig: access token longer than " + std::to_string(msg::kMaxTokenBytes) + " bytes"};
  if (!config.pairing_code.empty()) {
    if (!canonical_pairing_code(config.pairing_code))
      return Error{"NetHostConfig: pairing code '" + config.pairing_code + "' is not " +
                   std::to_string(kPairingCodeSymbols) + " symbols of Crockford's base32"};
    // A client holding a code-shaped token would answer the code's offer and fail.
    if (canonical_pairing_code(config.access_token))
      return Error{"NetHostConfig: with a pairing code, the access token must not look like one (" +
                   std::to_string(kPairingCodeSymbols) + " base32 symbols)"};
  }
  if (config.encrypt_stream && config.access_token.empty() && config.pairing_code.empty())
    return Error{"NetHostConfig: encrypt_stream needs an access token (the stream's keys come from proving it)"};
  if (!config.access_token.empty() || !config.pairing_code.empty())
    if (auto s = auth_init(); !s) return s.error();
  auto impl = std::make_unique<Impl>();
  impl->cfg = std::move(config);
  if (auto s = impl->enet.acquire(); !s) return s.error();
  auto addr = detail::resolve(impl->cfg.bind);
  if (!addr) return addr.error();
  // Loopback unless asked otherwise (NetHostConfig::bind): clients on other machines
  // reach the host only with an explicit --bind.
  auto host = detail::create_host(&addr.value(), impl->cfg.max_clients + impl->cfg.admission.spare_peers,
                                  detail::kHostWaitingBytesPerPeer);
  if (!host) return Error{host.message() + " (bind " + to_string(impl->cfg.bind) + ")"};
  impl->host = host.value();
  // ENet's own per-address check on connect requests (any peer state but its own
  // outgoing connects): one address cannot take every slot.
  impl->host->duplicatePeers = impl->cfg.admission.max_peers_per_address;
  impl->admission = std::make_unique<AdmissionGuard>(impl->cfg.admission);
  impl->last_summary = Clock::now();
  impl->next_summary = impl->last_summary + impl->cfg.admission.summary_interval;
  impl->host->maximumPacketSize = detail::kHostIncomingPacketBytes;  // raised only to send (HostSendLimit)
  impl->session = impl->cfg.session_id;
  if (impl->session == 0) {
    std::random_device rd;
    impl->session = (std::uint64_t{rd()} << 32) ^ rd() ^ 1u;
  }
  Impl* raw = impl.get();
  impl->thread = std::thread([raw] { raw->run(); });
  return std::unique_ptr<NetHost>(new NetHost(std::move(impl)));
}

std::uint16_t NetHost::port() const noexcept { return impl_->host->address.port; }
std::uint64_t NetHost::session_id() const noexcept { return impl_->session; }

std::vector<HostEvent> NetHost::poll() {
  std::lock_guard lock(impl_->mu);
  std::vector<HostEvent> out(std::make_move_iterator(impl_->events.begin()), std::make_move_iterator(impl_->events.end()));
  impl_->events.clear();
  return out;
}

bool NetHost::wait(std::chrono::milliseconds timeout) {
  std::unique_lock lock(impl_->mu);
  return impl_->cv.wait_for(lock, timeout, [this] { return !impl_->events.empty(); });
}

Status NetHost::send(std::uint32_t client, const wire::Message& m) {
  const msg::MessageType type = wire::type_of(m);
  if (msg::direction_of(type) != msg::Direction::HostToClient)
    return Error{std::string("NetHost::send: ") + msg::to_string(type) + " is a client->host message"};
  auto bytes = wire::encode(m);
  if (!bytes) return bytes.error();
  return send_encoded(client, type, std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes).value()));
}

Status NetHost::send_encoded(std::uint32_t client, msg::MessageType type,
                             std::shared_ptr<const std::vector<std::uint8_t>> frame) {
  if (!frame || frame->size() < wire::kHeaderBytes) return Error{"NetHost::send_encoded: empty frame"};
  if (msg::direction_of(type) != msg::Direction::HostToClient)
    return Error{std::string("NetHost::send_encoded: ") + msg::to_string(type) + " is a client->host message"};
  std::shared_ptr<StreamCipher> sealer;
  {
    std::lock_guard lock(impl_->mu);
    if (auto it = impl_->sealers.find(client); it != impl_->sealers.end()) sealer = it->second;
  }
  // Sealed here, on the caller's thread, like the encoding: a big batch never stalls the
  // service loop. Two threads sealing for one client may queue out of counter order; the
  // receiver's window accepts that.
  if (sealer) frame = std::make_shared<const std::vector<std::uint8_t>>(sealer->seal(*frame));
  std::lock_guard lock(impl_->mu);
  impl_->outbox.push_back(HostOutgoing{client, type, std::move(frame)});
  return Ok{};
}

void NetHost::disconnect(std::uint32_t client) {
  std::lock_guard lock(impl_->mu);
  impl_->outbox.push_back(HostOutgoing{client, msg::MessageType::Refuse, nullptr});
}

std::size_t NetHost::pending_bytes(std::uint32_t client) const {
  std::lock_guard lock(impl_->mu);
  auto it = impl_->pending.find(client);
  if (it == impl_->pending.end()) return 0;
  const auto v = it->second->load();
  return v > 0 ? static_cast<std::size_t>(v) : 0;
}

std::size_t NetHost::client_count() const {
  std::lock_guard lock(impl_->mu);
  return impl_->pending.size();
}

HostCounters NetHost::counters() const {
  std::lock_guard lock(impl_->mu);
  return impl_->counters;
}

}  // namespace gauss::net
