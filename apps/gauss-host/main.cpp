// gauss-host: streams an evolving scene to VR/desktop clients over ENet.
//
//   gauss-host [--bind HOST:PORT] [--token T [--encrypt]] [--scene synthetic:V | FILE | FOLDER]
//              [--labels F] [--objects F] [--rgbd DIR | --mesh M.ply] [--epoch-period S]
//              [--max-budget N] [--rho R] [--min-opacity A] [--max-scale S] [--min-support N]
//              [--gaussians N] [--epochs N] [--seed N] [--max-clients N] [--duration S]
//              [--surface-voxel M] [--events FILE] [--sessions FILE] [--dump-sent DIR]
//              [--max-clients-per-address N] [--session-open-rate HZ] [--handshake-timeout S] [--quiet]
//              (options.cpp; --help lists them)
//
// Binds 127.0.0.1 by default: other machines reach the host only with an explicit
// --bind. The scene (scene_feed.h) produces epochs every --epoch-period seconds: the
// synthetic trajectory until it ends, a snapshot folder whenever a new snapshot appears
// (followed live); the host keeps serving the latest epoch (clients may still connect,
// move and query) until --duration passes or SIGINT/SIGTERM. Once a second it prints the
// epoch, clients, edits/s and bytes/s; on exit, a summary. --events writes every session's
// stage events as JSON lines; --sessions writes where it listens and every client that
// joins and leaves, with what it was sent, as JSON lines (session_record.h: scripts read
// that, never the log, where client names appear escaped); --dump-sent writes what each
// client was sent when its session ends (dump_sent.h).
//
// Exit status: 0 stopped by --duration or a signal; 1 the scene or the transport failed
// (the message says which); 2 bad arguments.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <system_error>
#include <thread>

#include "dump_sent.h"
#include "gauss/engine/log_text.h"
#include "gauss/net/auth.h"
#include "gauss/net/session_host.h"
#include "options.h"
#include "scene_feed.h"
#include "session_record.h"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

}  // namespace

int main(int argc, char** argv) {
  gauss::host_app::Options o;
  if (auto rc = gauss::host_app::parse_options(argc, argv, o)) return *rc;
  if (o.token == "auto") {
    if (auto st = gauss::net::auth_init(); !st) {
      std::fprintf(stderr, "gauss-host: %s\n", st.message().c_str());
      return 1;
    }
    o.token = gauss::net::generate_access_token();
    o.pairing_code = gauss::net::generate_pairing_code();
    std::printf("gauss-host: access token (clients pass it with --token): %s\n", o.token.c_str());
    std::printf("gauss-host: pairing code (short to type, accepted instead of the token): %s\n",
                o.pairing_code.c_str());
    std::fflush(stdout);
  } else if (!o.token.empty()) {
    if (auto weak = gauss::net::weak_token_reason(o.token))
      std::fprintf(stderr, "gauss-host: warning: %s\n", weak->c_str());
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  gauss::SceneStore store;
  auto feed = gauss::host_app::SceneFeed::open(o, store, g_stop);
  if (!feed) {
    std::fprintf(stderr, "gauss-host: %s\n", feed.message().c_str());
    return 1;
  }
  gauss::CodecParams params = (*feed)->codec_params();
  // Interior records are wider than any leaf: the log-scale range reaches them.
  if (o.lod) params = gauss::fit_lod_codec_params(params);
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  std::unique_ptr<gauss::host_app::SessionRecord> record;
  if (!o.sessions_path.empty()) {
    auto r = gauss::host_app::SessionRecord::open(o.sessions_path);
    if (!r) {
      std::fprintf(stderr, "gauss-host: %s\n", r.message().c_str());
      return 1;
    }
    record = std::move(r).value();
  }

  gauss::net::SessionHostConfig hc;
  hc.net.bind = o.bind;
  hc.net.access_token = o.token;  // proved by CPace; never sent
  hc.net.pairing_code = o.pairing_code;
  hc.net.encrypt_stream = o.encrypt;
  hc.net.max_clients = o.max_clients;
  hc.net.admission.max_clients_per_address = o.max_clients_per_address;
  hc.net.admission.session_open_rate_hz = o.session_open_rate_hz;
  hc.net.handshake_timeout = std::chrono::milliseconds(static_cast<long long>(o.handshake_timeout_s * 1000.0));
  hc.net.admission.pending_timeout = hc.net.handshake_timeout;
  if (o.max_budget > 0) hc.session.max_capacity = o.max_budget;
  hc.session.default_rho = o.rho;
  hc.session.view = (*feed)->view();
  if (o.lod) hc.session.lod = gauss::LodConfig{};
  if (o.min_opacity > 0.0f || o.max_scale > 0.0f || o.min_support > 0) {
    gauss::EligibilityConfig ec;
    ec.min_opacity = o.min_opacity;
    ec.max_scale = o.max_scale > 0.0f ? o.max_scale : std::numeric_limits<float>::max();
    ec.min_support = o.min_support;
    hc.session.eligibility = ec;
  }
  // Edits sent by sessions that have ended, for the status line and the summary.
  std::uint64_t closed_edits = 0, closed_batches = 0;
  // One line per client that leaves: what it was sent, as the checksum its published set
  // has once it converged (ClientState::published_checksum; scripts/soak compares them).
  // The name is the client's own text: escaped in the log (it cannot forge a line), exact
  // in the --sessions record.
  auto report_left = [&](std::uint32_t client, const std::string& name, const gauss::HostSession& session) {
    if (!session.accepted()) return;
    const std::uint64_t checksum = session.sent_checksum();
    std::printf("gauss-host: client %u '%s' left: sent %zu Gaussians, checksum %llu\n", client,
                gauss::escape_for_log(name).c_str(), session.sent_ids().size(),
                static_cast<unsigned long long>(checksum));
    std::fflush(stdout);
    if (record) record->left(seconds(), client, name, session.sent_ids().size(), checksum);
  };
  if (record)
    hc.on_session_opened = [&](std::uint32_t client, const std::string& name, const gauss::HostSession& session) {
      if (session.accepted()) record->joined(seconds(), client, name, session.capacity());
    };
  if (o.dump_sent_dir.empty()) {
    hc.on_session_closed = [&](std::uint32_t client, const std::string& name, const gauss::HostSession& session) {
      closed_edits += session.stats().edits_sent;
      closed_batches += session.stats().batches_sent;
      report_left(client, name, session);
    };
  } else {
    // Synchronous in the host loop: a sent set is at most a few 100k Gaussians.
    hc.on_session_closed = [&](std::uint32_t client, const std::string& name, const gauss::HostSession& session) {
      closed_edits += session.stats().edits_sent;
      closed_batches += session.stats().batches_sent;
      report_left(client, name, session);
      if (!session.accepted()) return;  // refused at the Hello: it was sent nothing
      const std::string stem = gauss::host_app::dump_file_stem(name, client);
      auto r = gauss::host_app::dump_sent(o.dump_sent_dir, stem, session, store, params);
      if (!r) {
        std::fprintf(stderr, "gauss-host: --dump-sent for client %u (%s): %s\n", client, stem.c_str(),
                     r.message().c_str());
        return;
      }
      std::printf("gauss-host: wrote %s (%zu Gaussians)\n", r->gaussians_path.c_str(), r->gaussians);
      if (!r->mesh_path.empty())
        std::printf("gauss-host: wrote %s (%zu triangles)\n", r->mesh_path.c_str(), r->triangles);
      std::fflush(stdout);
    };
  }
  auto host = gauss::net::SessionHost::start(hc, params);
  if (!host) {
    std::fprintf(stderr, "gauss-host: %s\n", host.message().c_str());
    return 1;
  }
  std::ofstream events;
  if (!o.events_path.empty()) {
    events.open(o.events_path);
    if (!events) {
      std::fprintf(stderr, "gauss-host: cannot write events to %s\n", o.events_path.c_str());
      return 1;
    }
  }
  if (!o.dump_sent_dir.empty()) {
    // Said now rather than at the first session's end; the host serves on regardless.
    std::error_code ec;
    std::filesystem::create_directories(o.dump_sent_dir, ec);
    if (ec)
      std::fprintf(stderr, "gauss-host: --dump-sent: cannot create %s: %s (dumps will fail)\n",
                   o.dump_sent_dir.c_str(), ec.message().c_str());
  }
  std::printf("gauss-host: serving %s: %zu Gaussians, SH degree %d, %zu objects, on %s:%u, session %016llx%s\n",
              (*feed)->describe().c_str(), store.size(), store.sh_degree(), store.objects().size(), o.bind.host.c_str(), (*host)->net().port(), static_cast<unsigned long long>((*host)->net().session_id()),
              o.token.empty() ? "" : o.encrypt ? ", token required, stream sealed" : ", token required");
  std::fflush(stdout);
  if (record) record->listening(o.bind.host, (*host)->net().port(), (*host)->net().session_id());
  auto edits_sent = [&] {
    std::uint64_t n = closed_edits;
    for (std::uint32_t id : (*host)->clients()) n += (*host)->session(id)->stats().edits_sent;
    return n;
  };
  double next_report = 1.0;
  std::uint64_t last_bytes = 0, last_edits = 0;
  std::size_t epochs_served = 1;
  int exit_code = 0;
  while (!g_stop.load()) {
    const double now = seconds();
    if (o.duration_s > 0.0 && now >= o.duration_s) break;
    // The next epoch waits while the hierarchy of this one is still being updated in the
    // background: the LoD clients get every epoch they waited for.
    auto stepped = (*host)->lod_busy() ? gauss::Expected<bool>(false) : (*feed)->step(store, now);
    if (!stepped) {
      std::fprintf(stderr, "gauss-host: %s\n", stepped.message().c_str());
      exit_code = 1;
      break;
    }
    if (*stepped) ++epochs_served;
    for (const std::string& line : (*feed)->take_messages()) std::printf("gauss-host: %s\n", line.c_str());
    (*host)->pump(store, now);
    if (events.is_open()) {
      for (std::uint32_t id : (*host)->clients()) {
        auto& log = (*host)->session(id)->events();
        log.write_jsonl(events);
        log.clear();
      }
    }
    if (!o.quiet && now >= next_report) {
      const auto c = (*host)->net().counters();
      const std::uint64_t edits = edits_sent();
      std::printf("t=%6.1fs epoch %llu%s clients %zu  edits/s %llu  sent %.2f MB/s  rejected %llu  refused %llu\n", now,
                  static_cast<unsigned long long>(gauss::to_underlying(store.epoch())),
                  (*feed)->live() ? "" : " (final)", (*host)->clients().size(),
                  static_cast<unsigned long long>(edits - last_edits), double(c.bytes_sent - last_bytes) / 1e6,
                  static_cast<unsigned long long>(c.rejected()),
                  static_cast<unsigned long long>(c.refused()));
      std::fflush(stdout);
      last_bytes = c.bytes_sent;
      last_edits = edits;
      next_report += 1.0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const std::uint64_t edits_total = edits_sent();
  (*host)->close_all();  // --dump-sent: the still-connected clients' dumps
  const auto c = (*host)->net().counters();
  const auto& hs = (*host)->stats();
  std::printf("gauss-host: stopping after %.1f s: %zu epochs served (last %llu), %llu session%s, %llu edits in %llu "
              "batches, %.2f MB sent, %llu messages rejected\n",
              seconds(), epochs_served, static_cast<unsigned long long>(gauss::to_underlying(store.epoch())),
              static_cast<unsigned long long>(hs.sessions_opened), hs.sessions_opened == 1 ? "" : "s",
              static_cast<unsigned long long>(edits_total),
              static_cast<unsigned long long>(closed_batches), double(c.bytes_sent) / 1e6,
              static_cast<unsigned long long>(c.rejected()));
  return exit_code;
}
