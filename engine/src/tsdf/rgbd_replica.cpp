// Replica layout index files: cam_params.json and traj.txt (see rgbd_replica.h).
#include "rgbd_replica.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "io/file_bytes.h"

namespace gauss::replica {
namespace fs = std::filesystem;
using nlohmann::json;

Expected<CameraParams> read_cam_params(const fs::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  const auto fail = [&](const std::string& what) { return Error{path.string() + ": " + what}; };
  json doc;
  try {  // nlohmann reports by exception; converted here, never escapes
    doc = json::parse(bytes->begin(), bytes->end());
  } catch (const json::parse_error& e) {
    return fail(std::string("not valid JSON: ") + e.what());
  }
  if (!doc.is_object() || !doc.contains("camera") || !doc["camera"].is_object())
    return fail("expected an object {\"camera\": {\"w\", \"h\", \"fx\", \"fy\", \"cx\", \"cy\", \"scale\"}}");
  const json& cam = doc["camera"];
  CameraParams p;
  std::string bad;
  const auto number = [&](const char* key, double& out) {
    if (!bad.empty()) return;
    if (!cam.contains(key)) {
      bad = std::string("camera.") + key + " is missing";
    } else if (!cam[key].is_number() || !std::isfinite(cam[key].get<double>())) {
      bad = std::string("camera.") + key + " is not a finite number";
    } else {
      out = cam[key].get<double>();
    }
  };
  double w = 0, h = 0;
  number("w", w);
  number("h", h);
  number("fx", p.fx);
  number("fy", p.fy);
  number("cx", p.cx);
  number("cy", p.cy);
  number("scale", p.depth_scale);
  if (!bad.empty()) return fail(bad);
  if (!(w >= 1 && w <= 16384 && h >= 1 && h <= 16384) || w != std::floor(w) || h != std::floor(h))
    return fail("camera.w and camera.h must be whole numbers in 1..16384");
  if (!(p.fx > 0) || !(p.fy > 0)) return fail("camera.fx and camera.fy must be > 0");
  if (!(p.depth_scale > 0)) return fail("camera.scale (depth units per metre) must be > 0");
  p.width = std::uint32_t(w);
  p.height = std::uint32_t(h);
  return p;
}

Expected<std::vector<TrajectoryRow>> read_trajectory(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return Error{path.string() + ": cannot open"};
  std::vector<TrajectoryRow> rows;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    TrajectoryRow row;
    const auto where = path.string() + " line " + std::to_string(line_no) + ": ";
    std::istringstream s(line);
    std::vector<double> v;
    std::string tok;
    while (s >> tok) {
      char* end = nullptr;
      const double x = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0' || !std::isfinite(x)) {
        row.error = where + "value " + std::to_string(v.size() + 1) + " ('" + tok + "') is not a finite number";
        break;
      }
      v.push_back(x);
    }
    if (row.error.empty() && v.size() != 16)
      row.error = where + "expected 16 numbers (a row-major 4x4 camera-to-world), found " + std::to_string(v.size());
    if (row.error.empty())
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) row.camera_to_world[c][r] = v[std::size_t(r * 4 + c)];
    rows.push_back(std::move(row));
  }
  if (in.bad()) return Error{path.string() + ": read error"};
  return rows;
}

}  // namespace gauss::replica
