// Camera path files: parsing with field-named errors, and pose interpolation.
#include "gauss/client/camera_path.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "gauss/engine/messages.h"

namespace gauss::client {

namespace {

using nlohmann::json;

struct Parser {
  std::string name;

  Error fail(const std::string& field, const std::string& what) const { return Error{name + ": " + field + ": " + what}; }

  Expected<double> number(const json& j, const std::string& field) const {
    if (!j.is_number()) return fail(field, "expected a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) return fail(field, "not a finite number");
    return v;
  }
  Expected<glm::dvec3> vec3(const json& j, const std::string& field) const {
    if (!j.is_array() || j.size() != 3) return fail(field, "expected 3 finite numbers");
    glm::dvec3 v{};
    for (int i = 0; i < 3; ++i) {
      auto c = number(j[static_cast<std::size_t>(i)], field + "[" + std::to_string(i) + "]");
      if (!c) return c.error();
      v[i] = *c;
    }
    return v;
  }
  Expected<CameraIntrinsics> intrinsics(const json& j) const {
    if (!j.is_object()) return fail("camera", "expected an object");
    CameraIntrinsics in;
    for (const char* key : {"width", "height", "fx", "fy", "cx", "cy"})
      if (!j.contains(key)) return fail(std::string("camera.") + key, "missing");
    for (const char* key : {"width", "height"}) {
      const json& v = j[key];
      if (!v.is_number_integer() || v.get<std::int64_t>() <= 0 || v.get<std::int64_t>() > 16384)
        return fail(std::string("camera.") + key, "expected an integer in 1..16384");
    }
    in.width = j["width"].get<std::uint32_t>();
    in.height = j["height"].get<std::uint32_t>();
    double* fields[] = {&in.fx, &in.fy, &in.cx, &in.cy};
    const char* keys[] = {"fx", "fy", "cx", "cy"};
    for (int i = 0; i < 4; ++i) {
      auto v = number(j[keys[i]], std::string("camera.") + keys[i]);
      if (!v) return v.error();
      *fields[i] = *v;
    }
    if (in.fx <= 0.0 || in.fy <= 0.0) return fail("camera.fx", "focal lengths must be > 0");
    return in;
  }
  Expected<PathKeyframe> keyframe(const json& j, const std::string& field) const {
    if (!j.is_object()) return fail(field, "expected an object");
    PathKeyframe k;
    if (!j.contains("t")) return fail(field + ".t", "missing");
    auto t = number(j["t"], field + ".t");
    if (!t) return t.error();
    if (*t < 0.0) return fail(field + ".t", "negative time");
    k.t = *t;
    for (auto [key, out] : {std::pair<const char*, glm::dvec3*>{"eye", &k.eye}, {"look_at", &k.look_at}}) {
      if (!j.contains(key)) return fail(field + "." + key, "missing");
      auto v = vec3(j[key], field + "." + key);
      if (!v) return v.error();
      *out = *v;
    }
    if (j.contains("up")) {
      auto v = vec3(j["up"], field + ".up");
      if (!v) return v.error();
      if (glm::length(*v) < 1e-9) return fail(field + ".up", "zero vector");
      k.up = *v;
    }
    if (j.contains("cut")) {
      if (!j["cut"].is_boolean()) return fail(field + ".cut", "expected true or false");
      k.cut = j["cut"].get<bool>();
    }
    const glm::dvec3 dir = k.look_at - k.eye;
    if (glm::length(dir) < 1e-9) return fail(field, "eye and look_at coincide");
    if (glm::length(glm::cross(glm::normalize(dir), glm::normalize(k.up))) < 1e-6)
      return fail(field, "the view direction is parallel to up");
    return k;
  }
  Expected<PathEvent> event(const json& j, const std::string& field) const {
    if (!j.is_object()) return fail(field, "expected an object");
    PathEvent e;
    if (!j.contains("t")) return fail(field + ".t", "missing");
    auto t = number(j["t"], field + ".t");
    if (!t) return t.error();
    if (*t < 0.0) return fail(field + ".t", "negative time");
    e.t = *t;
    if (j.contains("query")) {
      const json& q = j["query"];
      if (!q.is_object()) return fail(field + ".query", "expected an object");
      if (!q.contains("rho")) return fail(field + ".query.rho", "missing");
      auto rho = number(q["rho"], field + ".query.rho");
      if (!rho) return rho.error();
      if (*rho < 0.0 || *rho > 1.0) return fail(field + ".query.rho", "outside [0, 1]");
      e.rho = static_cast<float>(*rho);
      if (q.contains("class")) {
        if (!q["class"].is_string() || q["class"].get<std::string>().empty() ||
            q["class"].get<std::string>().size() > msg::kMaxQueryTextBytes)
          return fail(field + ".query.class", "expected a non-empty class name");
        e.kind = PathEventKind::ClassQuery;
        e.text = q["class"].get<std::string>();
      } else if (q.contains("instance")) {
        if (!q["instance"].is_number_integer() || q["instance"].get<std::int64_t>() < 0 ||
            q["instance"].get<std::int64_t>() > std::numeric_limits<std::int32_t>::max())
          return fail(field + ".query.instance", "expected an object id >= 0");
        e.kind = PathEventKind::InstanceQuery;
        e.instance = ObjectId{q["instance"].get<std::int32_t>()};
      } else {
        return fail(field + ".query", "needs \"class\" or \"instance\"");
      }
      return e;
    }
    if (j.contains("clear")) {
      if (j["clear"] != true) return fail(field + ".clear", "expected true");
      e.kind = PathEventKind::Clear;
      return e;
    }
    if (j.contains("mode")) {
      const std::string m = j["mode"].is_string() ? j["mode"].get<std::string>() : "";
      if (m != "immediate" && m != "progressive") return fail(field + ".mode", "expected \"immediate\" or \"progressive\"");
      e.kind = PathEventKind::Mode;
      e.mode = m == "immediate" ? PublishMode::Immediate : PublishMode::Progressive;
      return e;
    }
    return fail(field, "unknown event (expected \"query\", \"clear\" or \"mode\")");
  }
};

}  // namespace

Expected<CameraPath> parse_camera_path(std::string_view text, std::string_view name) {
  Parser p{std::string(name)};
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    // nlohmann's message carries "at line L, column C".
    return Error{p.name + ": " + e.what()};
  }
  if (!root.is_object()) return p.fail("(top level)", "expected an object");
  CameraPath path;
  if (root.contains("camera")) {
    auto in = p.intrinsics(root["camera"]);
    if (!in) return in.error();
    path.intrinsics = *in;
  }
  if (root.contains("fps")) {
    auto fps = p.number(root["fps"], "fps");
    if (!fps) return fps.error();
    if (*fps < 1.0 || *fps > 1000.0) return p.fail("fps", "outside 1..1000");
    path.fps = *fps;
  }
  if (root.contains("settle_s")) {
    auto s = p.number(root["settle_s"], "settle_s");
    if (!s) return s.error();
    if (*s < 0.0 || *s > 3600.0) return p.fail("settle_s", "outside 0..3600");
    path.settle_s = *s;
  }
  if (!root.contains("keyframes") || !root["keyframes"].is_array() || root["keyframes"].empty())
    return p.fail("keyframes", "expected a non-empty array");
  const json& ks = root["keyframes"];
  for (std::size_t i = 0; i < ks.size(); ++i) {
    const std::string field = "keyframes[" + std::to_string(i) + "]";
    auto k = p.keyframe(ks[i], field);
    if (!k) return k.error();
    if (!path.keyframes.empty() && k->t < path.keyframes.back().t)
      return p.fail(field + ".t", "earlier than the keyframe before it");
    path.keyframes.push_back(*k);
  }
  if (root.contains("events")) {
    const json& es = root["events"];
    if (!es.is_array()) return p.fail("events", "expected an array");
    for (std::size_t i = 0; i < es.size(); ++i) {
      auto e = p.event(es[i], "events[" + std::to_string(i) + "]");
      if (!e) return e.error();
      path.events.push_back(*e);
    }
    std::stable_sort(path.events.begin(), path.events.end(),
                     [](const PathEvent& a, const PathEvent& b) { return a.t < b.t; });
  }
  return path;
}

Expected<CameraPath> read_camera_path(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{file.string() + ": cannot open the camera path file"};
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_camera_path(ss.str(), file.string());
}

Camera CameraPath::camera_at(double t, const CameraIntrinsics& in) const {
  Camera cam;
  cam.width = in.width;
  cam.height = in.height;
  cam.fx = in.fx;
  cam.fy = in.fy;
  cam.cx = in.cx;
  cam.cy = in.cy;
  // The last keyframe at or before t, and the next one (if it is not a cut).
  std::size_t i = 0;
  while (i + 1 < keyframes.size() && keyframes[i + 1].t <= t) ++i;
  const PathKeyframe& a = keyframes[i];
  glm::dvec3 eye = a.eye, target = a.look_at;
  if (i + 1 < keyframes.size() && !keyframes[i + 1].cut && t > a.t) {
    const PathKeyframe& b = keyframes[i + 1];
    const double s = std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0);
    eye = glm::mix(a.eye, b.eye, s);
    target = glm::mix(a.look_at, b.look_at, s);
  }
  cam.world_to_camera = glm::inverse(opencv_look_at(eye, target, a.up));
  return cam;
}

}  // namespace gauss::client
