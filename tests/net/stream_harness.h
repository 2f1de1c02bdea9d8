#pragma once
// End-to-end harness for the net tests: a synthetic evolving scene on a SessionHost,
// real ClientStates behind NetClients (optionally through a lossy UdpRelay), and a
// display loop that checks every client's invariants at every frame.
// All waits are on conditions with generous deadlines: no timing assertions.
#include <chrono>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/client_state.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/net/client_state_sink.h"
#include "gauss/net/session_host.h"
#include "gauss/net/udp_relay.h"

namespace gauss::test {

inline msg::HeadPose head_pose_of(const Camera& camera) { return head_pose_from_camera(camera); }

// The last lines the host and the clients logged, each with its time and source: a test
// that fails prints them, so a flake that cannot be reproduced still says what happened.
class LogTail {
 public:
  // A log function for `source`; it keeps the tail alive as long as its thread may call it.
  static std::function<void(const std::string&)> sink(std::shared_ptr<LogTail> tail, std::string source) {
    return [tail = std::move(tail), source = std::move(source)](const std::string& line) { tail->add(source, line); };
  }
  void add(const std::string& source, const std::string& line) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    char at[32];
    std::snprintf(at, sizeof at, "%8.3f s ", t);
    std::lock_guard lock(mu_);
    lines_.push_back(at + source + ": " + line);
    if (lines_.size() > kKept) lines_.pop_front();
  }
  std::string text() const {
    std::lock_guard lock(mu_);
    std::string out;
    for (const std::string& l : lines_) out += "\n    " + l;
    return out;
  }

 private:
  static constexpr std::size_t kKept = 60;
  const std::chrono::steady_clock::time_point start_{std::chrono::steady_clock::now()};
  mutable std::mutex mu_;
  std::deque<std::string> lines_;
};

struct StreamClient {
  std::string name;
  std::uint32_t capacity{0};
  std::unique_ptr<ClientState> state;
  std::unique_ptr<net::ClientStateSink> sink;
  std::unique_ptr<net::NetClient> net;
  std::uint64_t frames{0};
  std::size_t max_published{0};
  ViewState view{};
};

class StreamHarness {
 public:
  struct Options {
    std::size_t gaussians{20000};
    int epochs{6};
    double epoch_period_s{0.15};
    std::string access_token;
    bool encrypt_stream{false};  // seal the stream (needs access_token)
    // LoD on, its hierarchy updated in the background (lod_in_background); epochs wait
    // for it as gauss-host's loop does (SessionHost::lod_busy).
    bool lod{false};
  };

  explicit StreamHarness(Options o) : opt_(std::move(o)), start_(std::chrono::steady_clock::now()) {
    SyntheticSceneConfig sc;
    sc.target_gaussians = opt_.gaussians;
    sc.epochs = opt_.epochs;
    sc.seed = 7;
    auto s = SyntheticScene::create(sc);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.message());
    if (!s.ok()) return;
    scene_ = std::make_unique<SyntheticScene>(std::move(s).value());
    CodecParams params;
    params.sh_degree = 1;
    params.box.min = scene_->room_min() - glm::vec3(0.5f);
    params.box.max = scene_->room_max() + glm::vec3(0.5f);
    if (opt_.lod) params = fit_lod_codec_params(params);
    net::SessionHostConfig hc;
    if (opt_.lod) {
      hc.session.lod = LodConfig{};
      hc.lod_in_background = true;
    }
    hc.net.bind.port = 0;
    hc.net.access_token = opt_.access_token;
    hc.net.encrypt_stream = opt_.encrypt_stream;
    hc.net.peer_timeout_min = std::chrono::milliseconds(500);
    hc.net.peer_timeout_max = std::chrono::milliseconds(2000);
    hc.net.log = LogTail::sink(logs_, "host");
    hc.session.access_token = opt_.access_token;
    auto h = net::SessionHost::start(hc, params);
    EXPECT_TRUE(h.ok()) << (h.ok() ? "" : h.message());
    if (!h.ok()) return;
    host_ = std::move(h).value();
    produce();  // the host streams from epoch 1 on
  }

  bool ready() const { return scene_ && host_; }
  net::SessionHost& host() { return *host_; }
  const SceneStore& store() const { return store_; }
  bool scene_finished() const { return scene_->finished(); }
  double now() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

  std::uint16_t port() const { return host_->net().port(); }

  // A fresh client process: new ClientState, new NetClient to `port`.
  std::unique_ptr<StreamClient> connect(const std::string& name, std::uint32_t capacity, std::uint16_t port,
                                        int camera = 0) {
    auto c = std::make_unique<StreamClient>();
    c->name = name;
    c->capacity = capacity;
    gauss::ClientConfig cc;
    cc.capacity = capacity;
    cc.name = name;
    auto st = ClientState::create(0, cc);
    EXPECT_TRUE(st.ok()) << (st.ok() ? "" : st.message());
    if (!st.ok()) return nullptr;
    c->state = std::make_unique<ClientState>(std::move(st).value());
    const Camera& cam = scene_->trajectory()[static_cast<std::size_t>(camera) % scene_->trajectory().size()];
    const msg::HeadPose pose = head_pose_of(cam);
    c->view.eye = pose.position;
    const glm::dmat3 r_cw(cam.world_to_camera);
    c->view.forward = glm::normalize(glm::vec3(glm::transpose(r_cw) * glm::dvec3(0, 0, 1)));
    c->state->send_pose(pose);  // queued; resent after every Welcome
    c->sink = std::make_unique<net::ClientStateSink>(*c->state, [this] { return now(); });
    net::NetClientConfig nc;
    nc.server = {"127.0.0.1", port};
    nc.slot_capacity = capacity;
    nc.access_token = opt_.access_token;
    nc.name = name;
    nc.peer_timeout_min = std::chrono::milliseconds(500);
    nc.peer_timeout_max = std::chrono::milliseconds(2000);
    nc.connect_timeout = std::chrono::milliseconds(1000);
    nc.log = LogTail::sink(logs_, name);
    auto n = net::NetClient::start(nc, *c->sink);
    EXPECT_TRUE(n.ok()) << (n.ok() ? "" : n.message());
    if (!n.ok()) return nullptr;
    c->net = std::move(n).value();
    return c;
  }

  // One host pump and one display frame per client, with every invariant checked.
  void step(const std::vector<StreamClient*>& clients) {
    if (!scene_->finished() && now() >= next_epoch_at_ && !host_->lod_busy()) produce();
    host_->pump(store_, now());
    for (StreamClient* c : clients) {
      c->sink->with_state([&](ClientState& s) {
        auto f = s.frame(c->view, now(), c->frames);
        ASSERT_TRUE(f.ok()) << c->name << ": " << f.message();
        s.frame_rendered(now(), c->frames);
        ++c->frames;
        auto ok = s.check();
        ASSERT_TRUE(ok.ok()) << c->name << " frame " << c->frames << ": " << ok.message();
        ASSERT_LE(s.slots().size(), c->capacity) << c->name;
        c->max_published = std::max<std::size_t>(c->max_published, s.slots().size());
      });
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(4));
  }

  // Exact convergence: the client's published set equals its desired set equals what
  // the host's session last sent, by checksum of ids and records, nothing pending,
  // the newest batch acknowledged.
  bool converged(StreamClient& c) {
    const std::uint32_t id = c.sink->client_id();
    HostSession* hs = host_->session(id);
    if (hs == nullptr || !scene_->finished()) return false;
    const auto ack = hs->last_ack();
    if (!ack || ack->last_batch_id != hs->last_batch_id()) return false;
    const std::uint64_t sent = hs->sent_checksum();
    return c.sink->with_state([&](ClientState& s) {
      return s.welcomed() && s.desired().pending_count() == 0 && s.last_batch_id() == hs->last_batch_id() &&
             s.desired().desired_checksum() == sent && s.published_checksum() == sent &&
             s.desired().desired_count() == hs->sent_ids().size() && s.desired().received_epoch() == store_.epoch();
    });
  }

  // Steps until every client converged (true) or the deadline passes.
  bool run_until_converged(const std::vector<StreamClient*>& clients, std::chrono::seconds deadline) {
    const auto until = std::chrono::steady_clock::now() + deadline;
    while (std::chrono::steady_clock::now() < until) {
      step(clients);
      if (::testing::Test::HasFatalFailure()) return false;
      bool all = true;
      for (StreamClient* c : clients) all = all && converged(*c);
      if (all) return true;
    }
    return false;
  }

  // The host's and clients' last log lines, oldest first.
  std::string log_tail() const { return "\n  last log lines:" + logs_->text(); }

  std::string describe(StreamClient& c) {
    const std::uint32_t id = c.sink->client_id();
    HostSession* hs = host_->session(id);
    std::string out = c.name + ": client id " + std::to_string(id);
    if (hs) {
      out += ", host sent " + std::to_string(hs->sent_ids().size()) + " ids in " + std::to_string(hs->last_batch_id()) +
             " batches, acked " + std::to_string(hs->last_ack() ? hs->last_ack()->last_batch_id : 0);
    } else {
      out += ", no host session";
    }
    if (c.net) {
      // The transport's side: whether it ever got through (a failure that never welcomed
      // says here whether the host refused it, or every attempt timed out).
      static constexpr const char* kStatus[] = {"connecting", "connected", "refused", "stopped"};
      const net::ClientCounters k = c.net->counters();
      out += "; transport " + std::string(kStatus[static_cast<int>(c.net->status())]) + ", " +
             std::to_string(k.connects) + " connects, " + std::to_string(k.welcomes) + " welcomes, " +
             std::to_string(k.failed_attempts) + " failed attempts, " + std::to_string(k.turned_away) +
             " turned away, " + std::to_string(k.disconnects) +
             " disconnects" + (k.last_rejection.empty() ? "" : ", last rejection '" + k.last_rejection + "'");
    }
    const net::HostCounters hk = host_->net().counters();
    out += "; host counters: " + std::to_string(hk.connections) + " connections, " + std::to_string(hk.accepted) +
           " accepted, " + std::to_string(hk.refused()) + " refused, " + std::to_string(hk.handshake_timeouts) +
           "+" + std::to_string(hk.handshake_evicted) + " handshakes timed out/evicted, " +
           std::to_string(hk.pending_timeouts) + "+" + std::to_string(hk.pending_evicted) +
           " connect requests timed out/evicted, " + std::to_string(hk.disconnects) + " disconnects, " +
           std::to_string(host_->stats().sessions_opened) + " sessions opened, " +
           std::to_string(host_->stats().sessions_closed) + " closed";
    c.sink->with_state([&](ClientState& s) {
      out += "; client desired " + std::to_string(s.desired().desired_count()) + " published " +
             std::to_string(s.slots().size()) + " pending " + std::to_string(s.desired().pending_count()) +
             " last batch " + std::to_string(s.last_batch_id()) + " rejected " +
             std::to_string(s.stats().rejected_messages) + " (" + s.stats().last_rejection + ")";
    });
    return out;
  }

 private:
  void produce() {
    auto s = scene_->produce(store_);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.message());
    next_epoch_at_ = now() + opt_.epoch_period_s;
  }

  Options opt_;
  std::chrono::steady_clock::time_point start_;
  std::shared_ptr<LogTail> logs_{std::make_shared<LogTail>()};
  std::unique_ptr<SyntheticScene> scene_;
  SceneStore store_;
  std::unique_ptr<net::SessionHost> host_;
  double next_epoch_at_{0.0};
};

}  // namespace gauss::test
