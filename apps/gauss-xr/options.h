#pragma once
// gauss-xr's command line (CLI11): the headset client's options, as gauss-view's where they
// mean the same (host, token, name, budget, mode). On Android the same struct is filled
// from the launch intent's extras instead (docs/quest.md).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <glm/vec3.hpp>

#include "gauss/engine/publisher.h"
#include "gauss/net/address.h"

namespace gauss::xr_app {

struct XrOptions {
  net::Endpoint host{};
  std::string token;
  std::string name{"gauss-xr"};
  std::uint32_t budget{200000};        // M, the client's slots
  PublishMode mode{PublishMode::Progressive};
  double rho{0.9};                     // a query's share of the budget (the thumbstick moves it)
  bool stage{false};                   // STAGE reference space (floor origin) instead of LOCAL
  double eye_height{1.6};              // with stage: metres above the floor where a capture's origin goes
  std::optional<glm::dvec3> up;        // --up: the scene's up instead of the one its host announces
  bool highlight{true};                // tint the active query's objects
  bool publication_thread{true};       // publication off the display thread
  std::uint64_t max_frames{0};         // ask the runtime to exit after this many frames (0: never)
  std::filesystem::path out;           // on exit: summary.json, final_slot_ids.json, the last eyes' cameras
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, XrOptions& out);

}  // namespace gauss::xr_app
