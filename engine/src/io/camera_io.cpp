// Camera JSON reader/writer. nlohmann::json throws on malformed text; the throw is caught
// here and turned into an Error, so callers never see an exception.
#include "gauss/engine/camera_io.h"

#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "io/file_bytes.h"

namespace gauss {
namespace {

using nlohmann::json;

Error cam_error(std::string_view name, const std::string& what) { return Error{std::string(name) + ": " + what}; }

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// A required (or optional, when `fallback` is given) finite number.
Expected<double> get_number(const json& j, const char* key, std::string_view name, const double* fallback = nullptr) {
  const auto it = j.find(key);
  if (it == j.end()) {
    if (fallback) return *fallback;
    return cam_error(name, std::string("missing key '") + key + "'");
  }
  if (!it->is_number()) return cam_error(name, std::string("key '") + key + "' must be a number, got " + it->type_name());
  const double v = it->get<double>();
  if (!std::isfinite(v)) return cam_error(name, std::string("key '") + key + "' is not finite");
  return v;
}

Expected<std::uint32_t> get_dimension(const json& j, const char* key, std::string_view name) {
  auto v = get_number(j, key, name);
  if (!v) return v.error();
  if (*v != std::floor(*v) || *v < 1 || *v > kMaxCameraDimension)
    return cam_error(name, std::string("key '") + key + "' must be an integer in 1.." +
                               std::to_string(kMaxCameraDimension) + ", got " + num(*v));
  return static_cast<std::uint32_t>(*v);
}

Expected<glm::dmat4> get_matrix(const json& j, std::string_view name) {
  const auto it = j.find("world_to_camera");
  if (it == j.end()) return cam_error(name, "missing key 'world_to_camera'");
  const std::string shape = "key 'world_to_camera' must be a 4x4 row-major matrix as 4 arrays of 4 numbers";
  if (!it->is_array() || it->size() != 4) return cam_error(name, shape);
  glm::dmat4 m(1.0);
  for (std::size_t r = 0; r < 4; ++r) {
    const json& row = (*it)[r];
    if (!row.is_array() || row.size() != 4) return cam_error(name, shape + " (row " + std::to_string(r) + ")");
    for (std::size_t c = 0; c < 4; ++c) {
      const json& e = row[c];
      if (!e.is_number())
        return cam_error(name, "world_to_camera[" + std::to_string(r) + "][" + std::to_string(c) + "] is not a number");
      // File rows are matrix rows; GLM indexes m[column][row].
      m[static_cast<glm::length_t>(c)][static_cast<glm::length_t>(r)] = e.get<double>();
    }
  }
  return m;
}

}  // namespace

Status validate_camera(const Camera& c, std::string_view name) {
  if (c.width < 1 || c.width > kMaxCameraDimension || c.height < 1 || c.height > kMaxCameraDimension)
    return cam_error(name, "image size " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                               " must be within 1.." + std::to_string(kMaxCameraDimension));
  const std::pair<const char*, double> focal[] = {{"fx", c.fx}, {"fy", c.fy}};
  for (const auto& [key, v] : focal)
    if (!std::isfinite(v) || !(v > 0)) return cam_error(name, std::string(key) + " must be finite and > 0, got " + num(v));
  if (!std::isfinite(c.cx) || !std::isfinite(c.cy)) return cam_error(name, "cx/cy must be finite");
  if (!std::isfinite(c.near_plane) || !(c.near_plane > 0))
    return cam_error(name, "near must be finite and > 0, got " + num(c.near_plane));
  if (!std::isfinite(c.far_plane) || !(c.far_plane > c.near_plane))
    return cam_error(name, "far (" + num(c.far_plane) + ") must be finite and greater than near (" +
                               num(c.near_plane) + ")");
  const glm::dmat4& m = c.world_to_camera;
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row)
      if (!std::isfinite(m[col][row]))
        return cam_error(name, "world_to_camera[" + std::to_string(row) + "][" + std::to_string(col) + "] is not finite");
  const double bottom[4] = {m[0][3], m[1][3], m[2][3], m[3][3]};
  const double want[4] = {0, 0, 0, 1};
  for (int k = 0; k < 4; ++k)
    if (std::abs(bottom[k] - want[k]) > 1e-9)
      return cam_error(name, "world_to_camera bottom row must be 0 0 0 1, got " + num(bottom[0]) + " " + num(bottom[1]) +
                                 " " + num(bottom[2]) + " " + num(bottom[3]));
  // R^T R = I for an orthonormal rotation block.
  double deviation = 0.0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double dot = 0.0;
      for (int r = 0; r < 3; ++r) dot += m[a][r] * m[b][r];
      deviation = std::max(deviation, std::abs(dot - (a == b ? 1.0 : 0.0)));
    }
  if (deviation > kCameraRotationTolerance)
    return cam_error(name, "world_to_camera rotation is not orthonormal: max |R^T R - I| = " + num(deviation) +
                               " (tolerance " + num(kCameraRotationTolerance) + ")");
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2]) -
                     m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2]) +
                     m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2]);
  if (det < 0)
    return cam_error(name, "world_to_camera rotation has determinant " + num(det) + " (a reflection, not a rotation)");
  return Ok{};
}

Expected<Camera> parse_camera_json(std::string_view text, std::string_view name) {
  json j;
  try {
    j = json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    return cam_error(name, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) return cam_error(name, std::string("expected a JSON object, got ") + j.type_name());
  Camera c;
  auto w = get_dimension(j, "width", name);
  if (!w) return w.error();
  auto h = get_dimension(j, "height", name);
  if (!h) return h.error();
  c.width = *w;
  c.height = *h;
  double* fields[] = {&c.fx, &c.fy, &c.cx, &c.cy};
  const char* keys[] = {"fx", "fy", "cx", "cy"};
  for (int k = 0; k < 4; ++k) {
    auto v = get_number(j, keys[k], name);
    if (!v) return v.error();
    *fields[k] = *v;
  }
  const double default_near = c.near_plane, default_far = c.far_plane;
  auto near_plane = get_number(j, "near", name, &default_near);
  if (!near_plane) return near_plane.error();
  auto far_plane = get_number(j, "far", name, &default_far);
  if (!far_plane) return far_plane.error();
  c.near_plane = *near_plane;
  c.far_plane = *far_plane;
  auto m = get_matrix(j, name);
  if (!m) return m.error();
  c.world_to_camera = *m;
  if (Status st = validate_camera(c, name); !st) return st.error();
  // Within 1e-9 of 0 0 0 1: store it exactly so later products stay rigid.
  c.world_to_camera[0][3] = c.world_to_camera[1][3] = c.world_to_camera[2][3] = 0.0;
  c.world_to_camera[3][3] = 1.0;
  return c;
}

Expected<Camera> read_camera_json(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  return parse_camera_json(std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()), path.string());
}

Expected<std::string> camera_to_json(const Camera& c) {
  if (Status st = validate_camera(c, "camera"); !st) return Error{"cannot write " + st.message()};
  json rows = json::array();
  for (int r = 0; r < 4; ++r) {
    json row = json::array();
    for (int col = 0; col < 4; ++col) row.push_back(c.world_to_camera[col][r]);
    rows.push_back(row);
  }
  json j = {{"width", c.width}, {"height", c.height}, {"fx", c.fx},         {"fy", c.fy},
            {"cx", c.cx},       {"cy", c.cy},         {"near", c.near_plane}, {"far", c.far_plane},
            {"world_to_camera", rows}};
  return j.dump(1) + "\n";
}

Status write_camera_json(const std::filesystem::path& path, const Camera& camera) {
  auto text = camera_to_json(camera);
  if (!text) return Error{path.string() + ": " + text.message()};
  return io::write_file_atomic(
      path, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text->data()), text->size()));
}

}  // namespace gauss
