// gauss-host: streams an evolving scene to VR/desktop clients over ENet.
//
//   gauss-host [--bind HOST:PORT] [--token T] [--scene synthetic:VARIANT]
//              [--gaussians N] [--epochs N] [--epoch-period S] [--seed N]
//              [--max-clients N] [--duration S] [--events FILE] [--quiet]
//
// Binds 127.0.0.1 by default: other machines reach the host only with an explicit
// --bind. New epochs of the synthetic scene are produced every --epoch-period seconds
// until the trajectory ends; the host then keeps serving the final scene (clients
// may still connect, move and query) until --duration passes or SIGINT/SIGTERM.
// Once a second it prints clients, epoch and wire throughput; --events writes every
// session's stage events as JSON lines.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <string>
#include <thread>

#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"
#include "gauss/net/session_host.h"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Options {
  gauss::net::Endpoint bind{};
  std::string token;
  int variant{0};
  std::size_t gaussians{100000};
  int epochs{12};
  double epoch_period_s{0.1};
  std::uint64_t seed{1};
  std::size_t max_clients{8};
  double duration_s{0.0};  // 0: until a signal
  double surface_voxel{0.04};  // TSDF voxel (m) for the surface fused from each epoch's frames; 0 = none
  std::string events_path;
  bool quiet{false};
};

int usage(const char* why) {
  std::fprintf(stderr,
               "gauss-host: %s\n"
               "usage: gauss-host [--bind HOST:PORT] [--token T] [--scene synthetic:VARIANT] [--gaussians N]\n"
               "                  [--epochs N] [--epoch-period S] [--seed N] [--max-clients N] [--duration S]\n"
               "                  [--surface-voxel M] [--events FILE] [--quiet]\n",
               why);
  return 2;
}

bool parse_number(const char* text, double& out) {
  char* end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0';
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    double num = 0.0;
    if (a == "--help" || a == "-h") {
      usage("streams an evolving synthetic scene to clients");
      return 0;
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (a == "--bind") {
      const char* v = value();
      if (!v) return usage("--bind needs HOST:PORT");
      auto e = gauss::net::parse_endpoint(v);
      if (!e) return usage(e.message().c_str());
      o.bind = e.value();
    } else if (a == "--token") {
      const char* v = value();
      if (!v) return usage("--token needs a value");
      o.token = v;
    } else if (a == "--scene") {
      const char* v = value();
      const std::string s = v ? v : "";
      if (s.rfind("synthetic:", 0) != 0 || !parse_number(s.c_str() + 10, num) || num < 0 || num > 3)
        return usage("--scene must be synthetic:0..3");
      o.variant = static_cast<int>(num);
    } else if (a == "--events") {
      const char* v = value();
      if (!v) return usage("--events needs a file");
      o.events_path = v;
    } else if (a == "--gaussians" || a == "--epochs" || a == "--epoch-period" || a == "--seed" ||
               a == "--max-clients" || a == "--duration" || a == "--surface-voxel") {
      const char* v = value();
      if (!v || !parse_number(v, num) || num < 0) return usage((a + " needs a non-negative number").c_str());
      if (a == "--gaussians") o.gaussians = static_cast<std::size_t>(num);
      if (a == "--epochs") o.epochs = static_cast<int>(num);
      if (a == "--epoch-period") o.epoch_period_s = num;
      if (a == "--seed") o.seed = static_cast<std::uint64_t>(num);
      if (a == "--max-clients") o.max_clients = static_cast<std::size_t>(num);
      if (a == "--duration") o.duration_s = num;
      if (a == "--surface-voxel") o.surface_voxel = num;
    } else {
      return usage(("unknown option " + a).c_str());
    }
  }

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
  std::printf("gauss-host: stopping\n");
  return 0;
}
