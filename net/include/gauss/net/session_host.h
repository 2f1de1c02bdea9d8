#pragma once
// SessionHost: NetHost + one engine HostSession per connected client. The host loop
// calls pump() between epochs; everything that decides what a client gets lives in
// HostSession (engine/), this class only routes typed messages between the two.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gauss/engine/codec.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/scene_store.h"
#include "gauss/net/host.h"
#include "gauss/net/worker_pool.h"

namespace gauss::net {

struct SessionHostConfig {
  NetHostConfig net{};
  HostSessionConfig session{};
  // A client whose link holds more than this many unacknowledged bytes is skipped by
  // pump() (its session diffs from what it was sent, so it catches up in one batch
  // when the link drains instead of queueing stale epochs).
  std::size_t max_pending_bytes{16u << 20};
  // Threads that tick the clients' sessions in parallel each pump (WorkerPool: the pump
  // thread counts as one; 1 = one after another; 0 = one per hardware thread). Each
  // session's selection + diff + encode only reads the scene, so N clients cost about
  // N / threads times one client's time.
  unsigned tick_threads{0};
  // With LoD (session.lod): the hierarchy is updated on a worker thread, started by pump()
  // when the scene has a new epoch (and taken up by a later pump), instead of inside the
  // first session's tick, where a 1M scene's first build held every client ~1 s and each 1 %
  // epoch 170-240 ms. Meanwhile the pump goes on (messages, acks, connections, sessions
  // without LoD) and the LoD sessions send nothing; they select once it stands for the epoch.
  // The loop should not commit another epoch while lod_busy(). Off: the first tick updates it.
  // A session's record of what it sent (sent_checksum, --dump-sent, --sessions) is its
  // differ's own copy, so an update that rewrites the hierarchy after a session's last batch
  // does not change what the session reports.
  bool lod_in_background{true};
  // Called with each session right before it is erased: on its client's disconnect
  // (inside pump()) and for every session still open in close_all(). `client_name` is
  // the name from the client's Hello. Runs on the thread calling pump()/close_all();
  // empty: nothing is called.
  std::function<void(std::uint32_t client, const std::string& client_name, const HostSession& session)>
      on_session_closed;
  // Called with each new session right after it answered its client's Hello (accepted()
  // says whether it welcomed it), on the thread calling pump(); empty: nothing is called.
  std::function<void(std::uint32_t client, const std::string& client_name, const HostSession& session)>
      on_session_opened;
};

struct SessionHostStats {
  std::uint64_t sessions_opened{0};
  std::uint64_t sessions_closed{0};
  std::uint64_t held_back{0};        // ticks skipped for a client whose link was behind
  std::uint64_t tick_errors{0};      // HostSession::tick failures (logged)
  std::uint64_t send_errors{0};      // messages the transport refused to queue (logged)
  std::uint64_t lod_failures{0};     // background hierarchy updates that failed (logged; leaves selected)
  std::string last_error;
};

class SessionHost {
 public:
  // Binds the transport. `params` are the codec parameters every session uses.
  static Expected<std::unique_ptr<SessionHost>> start(SessionHostConfig config, CodecParams params);

  // Routes queued client messages to their sessions (replies go straight out), opens
  // a session per new connection and closes it on disconnect, then ticks every
  // session and sends what it produced. Call from the host loop, between epochs.
  void pump(const SceneStore& scene, double now);
  // Ends every open session (on_session_closed runs for each) and disconnects its
  // client. The host loop calls it before it exits; the destructor does not, since
  // what the hook refers to may be gone by then.
  void close_all();

  NetHost& net() noexcept { return *net_; }
  const NetHost& net() const noexcept { return *net_; }
  // The session of a connected client (nullptr when none).
  HostSession* session(std::uint32_t client);
  std::vector<std::uint32_t> clients() const;
  const SessionHostStats& stats() const noexcept { return stats_; }
  // Whether a background hierarchy update is still outstanding (lod_in_background) while a
  // session may be waiting for it: the host loop holds its next epoch back until it clears,
  // so the sessions serve every epoch they wait for instead of waiting on the next one's
  // update. With no session it is false once the update has copied what it needs from the
  // scene (the worker copies it, not the serving thread: LodEpochHierarchy::reading_scene),
  // and the scene goes at its own pace meanwhile. The scene must not change while it is true.
  bool lod_busy() const;

 private:
  SessionHost(SessionHostConfig config, CodecParams params, std::unique_ptr<NetHost> net);
  void send_all(std::uint32_t client, const std::vector<wire::Message>& out);
  void log(const std::string& line);
  // Runs on_session_closed for `it` and erases it.
  void close(std::map<std::uint32_t, HostSession>::iterator it);
  // Starts the hierarchy's update for the scene's epoch, or takes a finished one up (and
  // logs a build, or an update of a second or more, once: the LoD clients waited for it).
  void advance_lod(const SceneStore& scene);

  SessionHostConfig config_;
  CodecParams params_;
  std::unique_ptr<NetHost> net_;
  std::map<std::uint32_t, HostSession> sessions_;
  std::map<std::uint32_t, std::string> client_names_;  // from each session's Hello
  SessionHostStats stats_;
  std::uint64_t lod_updates_seen_{0};  // the shared hierarchy's updates() advance_lod has looked at
  WorkerPool pool_;
};

}  // namespace gauss::net
