// gauss-host: streams an evolving scene to VR/desktop clients over ENet.
//
//   gauss-host [--bind HOST:PORT] [--token T] [--scene synthetic:VARIANT]
//              [--gaussians N] [--epochs N] [--epoch-period S] [--seed N]
//              [--max-clients N] [--duration S] [--surface-voxel M] [--events FILE]
//              [--dump-sent DIR] [--quiet]          (options.cpp; --help lists them)
//
// Binds 127.0.0.1 by default: other machines reach the host only with an explicit
// --bind. New epochs of the synthetic scene are produced every --epoch-period seconds
// until the trajectory ends; the host then keeps serving the final scene (clients
// may still connect, move and query) until --duration passes or SIGINT/SIGTERM.
// Once a second it prints clients, epoch and wire throughput; --events writes every
// session's stage events as JSON lines; --dump-sent writes what each client was sent
// when its session ends (dump_sent.h).
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
#include <optional>
#include <string>
#include <system_error>
#include <thread>

#include "dump_sent.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"
#include "gauss/net/session_host.h"
#include "options.h"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

}  // namespace

int main(int argc, char** argv) {
  gauss::host_app::Options o;
  if (auto rc = gauss::host_app::parse_options(argc, argv, o)) return *rc;

  gauss::SyntheticSceneConfig sc;
  sc.variant = o.variant;
  sc.seed = o.seed;
  sc.target_gaussians = o.gaussians;
  sc.epochs = o.epochs;
  auto scene = gauss::SyntheticScene::create(sc);
  if (!scene) {
    std::fprintf(stderr, "gauss-host: %s\n", scene.message().c_str());
    return 1;
  }
  gauss::SceneStore store;
  // The surface: each epoch's camera frames (the scene's exact ground-truth depth) are
  // fused into a TSDF, and the changed chunks enter the store in the following epoch.
  std::optional<gauss::TsdfVolume> surface;
  if (o.surface_voxel > 0.0) {
    gauss::TsdfConfig tc;
    tc.voxel_size = static_cast<float>(o.surface_voxel);
    auto v = gauss::TsdfVolume::create(tc);
    if (!v) {
      std::fprintf(stderr, "gauss-host: %s\n", v.message().c_str());
      return 1;
    }
    surface.emplace(std::move(*v));
  }
  // The codec box must cover every Gaussian the scene will ever hold: the room plus a
  // margin for the noisy first observations.
  gauss::CodecParams params;
  params.sh_degree = 1;
  params.box.min = scene->room_min() - glm::vec3(0.5f);
  params.box.max = scene->room_max() + glm::vec3(0.5f);

  gauss::net::SessionHostConfig hc;
  hc.net.bind = o.bind;
  hc.net.access_token = o.token;
  hc.net.max_clients = o.max_clients;
  hc.session.access_token = o.token;
  if (!o.dump_sent_dir.empty()) {
    // Synchronous in the host loop: a sent set is at most a few 100k Gaussians.
    hc.on_session_closed = [&](std::uint32_t client, const std::string& name, const gauss::HostSession& session) {
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
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::printf("gauss-host: serving synthetic:%d (%zu Gaussians, %d epochs) on %s:%u, session %016llx%s\n", o.variant,
              o.gaussians, o.epochs, o.bind.host.c_str(), (*host)->net().port(),
              static_cast<unsigned long long>((*host)->net().session_id()), o.token.empty() ? "" : ", token required");
  std::fflush(stdout);

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  double next_epoch = 0.0, next_report = 1.0;
  std::uint64_t last_bytes = 0;
  while (!g_stop.load()) {
    const double now = seconds();
    if (o.duration_s > 0.0 && now >= o.duration_s) break;
    if (!scene->finished() && now >= next_epoch) {
      if (auto s = scene->produce(store); !s) {
        std::fprintf(stderr, "gauss-host: epoch failed: %s\n", s.message().c_str());
        return 1;
      }
      if (surface) {
        for (const gauss::Camera& cam : scene->cameras_of_epoch(scene->produced() - 1))
          if (auto s = surface->integrate(gauss::synthetic_rgbd_frame(*scene, cam, store.epoch())); !s) {
            std::fprintf(stderr, "gauss-host: surface frame skipped: %s\n", s.message().c_str());
          }
        const auto edits = surface->extract_changed();
        if (!edits.empty()) {
          gauss::Status s = store.begin_next_epoch();
          if (s) s = gauss::apply_surface_edits(store, edits);
          if (s) s = store.commit_epoch();
          if (!s) {
            std::fprintf(stderr, "gauss-host: surface epoch failed: %s\n", s.message().c_str());
            return 1;
          }
        }
      }
      next_epoch = now + o.epoch_period_s;
    }
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
      std::printf("t=%6.1fs epoch %llu clients %zu  sent %.2f MB/s  rejected %llu  refused %llu\n", now,
                  static_cast<unsigned long long>(gauss::to_underlying(store.epoch())), (*host)->clients().size(),
                  double(c.bytes_sent - last_bytes) / 1e6,
                  static_cast<unsigned long long>(c.rejected()),
                  static_cast<unsigned long long>(c.refused_token + c.refused_version + c.refused_capacity +
                                                  c.refused_full + c.refused_malformed));
      std::fflush(stdout);
      last_bytes = c.bytes_sent;
      next_report += 1.0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  (*host)->close_all();  // --dump-sent: the still-connected clients' dumps
  std::printf("gauss-host: stopping\n");
  return 0;
}
