#pragma once
// gauss-host's command line (CLI11): the options, their defaults and their checks.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <glm/vec3.hpp>

#include "gauss/net/address.h"

namespace gauss::host_app {

struct Options {
  net::Endpoint bind{};        // 127.0.0.1 and the default port unless --bind
  std::string token;           // required access token; empty = none
  std::string pairing_code;    // accepted instead of the token (--token auto draws one); empty = none
  bool encrypt{false};         // --encrypt: sealed stream (needs a token)
  int variant{0};              // --scene synthetic:VARIANT
  std::optional<std::filesystem::path> scene_path;  // --scene FILE|FOLDER (else synthetic)
  std::optional<std::filesystem::path> labels;      // per-Gaussian object ids
  std::optional<std::filesystem::path> objects;     // objects JSON (class labels)
  std::optional<std::filesystem::path> rgbd;        // RGB-D capture fused into the surface
  std::optional<std::filesystem::path> mesh;        // fixed surface mesh PLY
  std::optional<glm::dvec3> up;                     // --up: the scene's up axis (else measured or the convention's)
  std::uint32_t rgbd_stride{4};  // a capture as the scene: a Gaussian per stride x stride pixels
  std::uint32_t max_budget{0};  // largest budget M granted to a client; 0 = the engine's maximum
  double rho{0.9};              // a query's share when the client asks for the host's default
  float min_opacity{0.0f};      // eligibility: all 0 = every Gaussian may be selected
  float max_scale{0.0f};        // metres; 0 = off
  std::uint32_t min_support{0};
  std::size_t gaussians{100000};
  int epochs{12};
  double epoch_period_s{0.1};  // replay rate: seconds between epochs
  double settle_s{2.0};        // a snapshot failing to load this recently written is waited for
  std::uint64_t seed{1};
  std::size_t max_clients{8};
  std::size_t max_clients_per_address{4};  // a headset is one address; loopback runs raise it
  double session_open_rate_hz{1.0};        // sessions opened per second per address (burst 8)
  double handshake_timeout_s{3.0};  // connect request, Hello and proof each within this
  double duration_s{0.0};      // 0: until SIGINT/SIGTERM
  double surface_voxel{0.04};  // TSDF voxel (m) for the surface fused from each epoch's frames; 0 = none
  std::string events_path;     // empty: no event log
  std::filesystem::path sessions_path;  // empty: no sessions record
  std::filesystem::path dump_sent_dir;  // empty: no dumps
  // --lod: a coarse background under the budget (LoD cut), on by default: what a client's
  // budget cannot hold in detail is sent coarse instead of left out. The sessions share one
  // hierarchy (about 0.6 KB per Gaussian for the host, whatever the number of clients).
  bool lod{true};
  bool quiet{false};
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line, CLI11's message printed), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, Options& out);

}  // namespace gauss::host_app
