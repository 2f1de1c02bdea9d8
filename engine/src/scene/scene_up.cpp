// The up vector of a scene file: --up, the trainer's cameras.json, or the 3DGS default
// (contract in scene_up.h). nlohmann::json throws on malformed text; the throw is caught
// here and turned into an Error.
#include "gauss/engine/scene_up.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include "gauss/engine/sym_eigen3.h"

#include "io/file_bytes.h"

namespace gauss {

namespace {

using nlohmann::json;

// The sign of each SH rest coefficient (3DGS order, coefficients 1..15) under the half turn
// about x: -1 where the basis function is odd in y and z together. Degree 1: y, z, x.
// Degree 2: xy, yz, 3z^2 - 1, xz, x^2 - y^2. Degree 3: y(3x^2 - y^2), xyz, y(4z^2 - x^2 - y^2),
// z(2z^2 - 3x^2 - 3y^2), x(4z^2 - x^2 - y^2), z(x^2 - y^2), x(x^2 - 3y^2).
constexpr float kHalfTurnXShSigns[kMaxShRest] = {-1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};

Error up_error(const std::filesystem::path& file, const std::string& what) { return Error{file.string() + ": " + what}; }

// obj[key] as three finite numbers; nullopt when absent or anything else.
std::optional<glm::dvec3> finite_vec3(const json& obj, const char* key) {
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_array() || it->size() != 3) return std::nullopt;
  glm::dvec3 v(0.0);
  for (std::size_t c = 0; c < 3; ++c) {
    const json& x = (*it)[c];
    if (!x.is_number() || !std::isfinite(x.get<double>())) return std::nullopt;
    v[static_cast<int>(c)] = x.get<double>();
  }
  return v;
}

}  // namespace

Expected<glm::dvec3> parse_up_axis(std::string_view text) {
  std::string t;
  for (char c : text) t.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  double sign = 1.0;
  std::string_view axis = t;
  if (!axis.empty() && (axis.front() == '+' || axis.front() == '-')) {
    sign = axis.front() == '-' ? -1.0 : 1.0;
    axis.remove_prefix(1);
  }
  glm::dvec3 up(0.0);
  if (axis == "x") up.x = sign;
  else if (axis == "y") up.y = sign;
  else if (axis == "z") up.z = sign;
  else return Error{"up axis '" + std::string(text) + "': expected one of +x -x +y -y +z -z"};
  return up;
}

std::string up_label(const glm::dvec3& up) {
  static constexpr const char* kAxes = "xyz";
  for (int a = 0; a < 3; ++a) {
    const glm::dvec3 other(a == 0 ? 0.0 : up.x, a == 1 ? 0.0 : up.y, a == 2 ? 0.0 : up.z);
    if (std::abs(std::abs(up[a]) - 1.0) < 1e-9 && glm::dot(other, other) < 1e-18)
      return std::string(up[a] < 0.0 ? "-" : "+") + kAxes[a];
  }
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.2f, %.2f, %.2f)", up.x, up.y, up.z);
  return buf;
}

std::optional<std::filesystem::path> find_trainer_cameras(const std::filesystem::path& scene) {
  std::error_code ec;
  // A followed folder (a trainer's RUN, or a folder of snapshots): the cameras are in it. A
  // SOG folder (meta.json) is one scene file, looked beside like the others.
  if (std::filesystem::is_directory(scene, ec) && !std::filesystem::is_regular_file(scene / "meta.json", ec)) {
    if (std::filesystem::is_regular_file(scene / "cameras.json", ec)) return scene / "cameras.json";
    return std::nullopt;
  }
  const std::filesystem::path dir = scene.parent_path();
  if (std::filesystem::is_regular_file(dir / "cameras.json", ec)) return dir / "cameras.json";
  // RUN/point_cloud/iteration_N/point_cloud.ply: the trainer writes RUN/cameras.json.
  const std::filesystem::path run = dir.parent_path().parent_path();
  if (dir.filename().string().rfind("iteration_", 0) == 0 && dir.parent_path().filename() == "point_cloud" &&
      std::filesystem::is_regular_file(run / "cameras.json", ec))
    return run / "cameras.json";
  return std::nullopt;
}

Expected<TrainerCapture> read_trainer_capture(const std::filesystem::path& file) {
  auto bytes = io::read_file_bytes(file);
  if (!bytes) return bytes.error();
  json j;
  try {
    j = json::parse(bytes->begin(), bytes->end());
  } catch (const json::exception& e) {
    return up_error(file, std::string("not JSON: ") + e.what());
  }
  if (!j.is_array()) return up_error(file, std::string("expected an array of cameras, got ") + j.type_name());
  if (j.empty()) return up_error(file, "no cameras");
  glm::dvec3 position_sum(0.0);
  std::vector<CameraAxes> axes;
  bool positions = true;  // every camera so far had a finite position
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string at = "camera " + std::to_string(i) + ": ";
    const json& cam = j[i];
    const auto rot = cam.is_object() ? cam.find("rotation") : cam.end();
    if (!cam.is_object() || rot == cam.end()) return up_error(file, at + "no 'rotation'");
    if (!rot->is_array() || rot->size() != 3) return up_error(file, at + "'rotation' must be 3 rows of 3 numbers");
    glm::dvec3 down(0.0), right(0.0);  // the camera's y (image down) and x axes in the world: columns 1, 0
    for (std::size_t r = 0; r < 3; ++r) {
      const json& row = (*rot)[r];
      if (!row.is_array() || row.size() != 3) return up_error(file, at + "'rotation' must be 3 rows of 3 numbers");
      for (std::size_t c = 0; c < 3; ++c)
        if (!row[c].is_number() || !std::isfinite(row[c].get<double>()))
          return up_error(file, at + "rotation[" + std::to_string(r) + "][" + std::to_string(c) + "] is not a finite number");
      down[static_cast<int>(r)] = row[1].get<double>();
      right[static_cast<int>(r)] = row[0].get<double>();
    }
    if (!(glm::length(down) > 1e-6)) return up_error(file, at + "the rotation's second column is zero");
    axes.push_back(CameraAxes{right, down});
    // Positions are optional: one camera without a usable one drops the mean, not the up.
    const auto pos = finite_vec3(cam, "position");
    if (pos) position_sum += *pos;
    positions = positions && pos.has_value();
  }
  auto up = capture_up(axes);
  if (!up) return up_error(file, up.message());
  TrainerCapture out;
  out.up = *up;
  out.cameras = j.size();
  if (positions) out.mean_position = position_sum / static_cast<double>(j.size());
  return out;
}

SceneUp choose_scene_up(const std::optional<glm::dvec3>& option, const std::filesystem::path& scene) {
  SceneUp out;
  if (option) {
    out.up = glm::normalize(*option);
    out.source = UpSource::Option;
    out.detail = "--up " + up_label(out.up);
    return out;
  }
  const auto cams = find_trainer_cameras(scene);
  if (!cams) return out;
  auto capture = read_trainer_capture(*cams);
  if (!capture) {
    out.problem = capture.message();
    return out;
  }
  out.up = capture->up;
  out.source = UpSource::TrainerCameras;
  out.detail = cams->string() + " (" + std::to_string(capture->cameras) + " capture cameras)";
  out.capture_position = capture->mean_position;
  return out;
}

Expected<glm::dvec3> capture_up(std::span<const CameraAxes> cameras) {
  glm::dvec3 sum(0.0);
  glm::dmat3 scatter(0.0);  // sum of r r^T over the unit right axes
  double n = 0.0;
  for (const CameraAxes& c : cameras) {
    const double dl = glm::length(c.down), rl = glm::length(c.right);
    if (!std::isfinite(dl + rl) || !(dl > 0.0)) continue;
    sum -= c.down / dl;
    n += 1.0;
    if (rl > 0.0) scatter += glm::outerProduct(c.right / rl, c.right / rl);
  }
  if (n == 0.0) return Error{"no camera has finite axes"};
  const double len = glm::length(sum);
  // Cameras looking from every side still agree on up; ups that cancel mean a capture
  // without one (or a broken file).
  if (!(len > 0.1 * n))
    return Error{"the cameras' up directions do not agree (mean length " + std::to_string(len / n) + ")"};
  const glm::dvec3 mean = sum / len;
  const SymEigen3 e = sym_eigen3(scatter);
  glm::dvec3 up = mean;
  if (e.values[1] >= 0.05 * n) {
    up = e.vectors[2];  // the normal of the plane the right axes span
  } else if (e.values[0] > 0.0) {
    up = mean - glm::dot(mean, e.vectors[0]) * e.vectors[0];  // level with the common right axis
  }
  const double ul = glm::length(up);
  if (!(ul > 1e-9)) return mean;
  up /= ul;
  if (glm::dot(up, mean) < 0.0) up = -up;
  return glm::dot(up, mean) >= std::sqrt(0.5) ? up : mean;
}

void half_turn_about_x(std::span<Gaussian> gaussians) {
  for (Gaussian& g : gaussians) {
    g.position = {g.position.x, -g.position.y, -g.position.z};
    // (0, 1, 0, 0) * q in (w, x, y, z) order: the turn applied after the Gaussian's own rotation.
    const glm::vec4 q = g.rotation;
    g.rotation = {-q[1], q[0], -q[3], q[2]};
    for (int k = 0; k < kMaxShRest; ++k) g.sh_rest[k] *= kHalfTurnXShSigns[k];
  }
}

}  // namespace gauss
