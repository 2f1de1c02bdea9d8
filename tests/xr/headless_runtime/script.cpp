// Script parsing: strict (an unknown key is an error, so a typo never silently falls back
// to a default) and never throws out of this file.
#include "script.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

namespace gauss::xr_headless {
namespace {

using nlohmann::json;

constexpr double kHalfPi = 1.57079632679489661923;

// Parsing state: the first error wins and names the JSON path where it was found.
struct Reader {
  std::string source;
  std::string error;

  bool fail(const std::string& path, const std::string& what) {
    if (error.empty()) error = source + ": " + path + ": " + what;
    return false;
  }

  bool only_keys(const json& obj, const std::string& path, std::initializer_list<const char*> keys) {
    if (!obj.is_object()) return fail(path, "expected an object");
    for (const auto& [key, value] : obj.items()) {
      if (std::none_of(keys.begin(), keys.end(), [&](const char* k) { return key == k; }))
        return fail(path + "." + key, "unknown key");
    }
    return true;
  }

  bool number(const json& v, const std::string& path, double lo, double hi, double& out) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < lo || v.get<double>() > hi) {
      std::ostringstream s;
      s << "expected a number in [" << lo << ", " << hi << "]";
      return fail(path, s.str());
    }
    out = v.get<double>();
    return true;
  }

  bool number_f(const json& v, const std::string& path, double lo, double hi, float& out) {
    double d = 0.0;
    if (!number(v, path, lo, hi, d)) return false;
    out = static_cast<float>(d);
    return true;
  }

  bool frame_index(const json& v, const std::string& path, std::uint64_t& out) {
    if (!v.is_number_unsigned()) return fail(path, "expected a frame index (an integer >= 0)");
    out = v.get<std::uint64_t>();
    return true;
  }

  bool boolean(const json& v, const std::string& path, bool& out) {
    if (!v.is_boolean()) return fail(path, "expected true or false");
    out = v.get<bool>();
    return true;
  }

  bool floats(const json& v, const std::string& path, std::size_t n, double lo, double hi, float* out) {
    if (!v.is_array() || v.size() != n) return fail(path, "expected an array of " + std::to_string(n) + " numbers");
    for (std::size_t i = 0; i < n; ++i)
      if (!number_f(v[i], path + "[" + std::to_string(i) + "]", lo, hi, out[i])) return false;
    return true;
  }

  // {"position": [x, y, z], "orientation": [w, x, y, z]}; the quaternion must be unit
  // length within 1e-3 (it is then normalized), so a mistyped rotation is caught.
  bool pose(const json& v, const std::string& path, XrPosef& out) {
    if (!only_keys(v, path, {"position", "orientation"})) return false;
    if (v.contains("position")) {
      float p[3];
      if (!floats(v["position"], path + ".position", 3, -1e4, 1e4, p)) return false;
      out.position = {p[0], p[1], p[2]};
    }
    if (v.contains("orientation")) {
      float q[4];
      if (!floats(v["orientation"], path + ".orientation", 4, -2.0, 2.0, q)) return false;
      const double len = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
      if (std::abs(len - 1.0) > 1e-3) return fail(path + ".orientation", "expected a unit quaternion [w, x, y, z]");
      out.orientation = {float(q[1] / len), float(q[2] / len), float(q[3] / len), float(q[0] / len)};
    }
    return true;
  }

  bool fov(const json& v, const std::string& path, XrFovf& out) {
    if (!only_keys(v, path, {"left", "right", "up", "down"})) return false;
    for (const char* key : {"left", "right", "up", "down"})
      if (!v.contains(key)) return fail(path, std::string("missing \"") + key + "\"");
    if (!number_f(v["left"], path + ".left", -kHalfPi, kHalfPi, out.angleLeft) ||
        !number_f(v["right"], path + ".right", -kHalfPi, kHalfPi, out.angleRight) ||
        !number_f(v["up"], path + ".up", -kHalfPi, kHalfPi, out.angleUp) ||
        !number_f(v["down"], path + ".down", -kHalfPi, kHalfPi, out.angleDown))
      return false;
    if (!(out.angleLeft < out.angleRight) || !(out.angleDown < out.angleUp))
      return fail(path, "expected left < right and down < up");
    return true;
  }

  bool hand(const json& v, const std::string& path, bool right, HandState& out) {
    const char* primary = right ? "a" : "x";
    const char* secondary = right ? "b" : "y";
    if (right) {
      if (!only_keys(v, path, {"aim", "grip", "trigger", "squeeze", "a", "b", "thumbstick", "thumbstick_click"}))
        return false;
    } else if (!only_keys(v, path, {"aim", "grip", "trigger", "squeeze", "x", "y", "menu", "thumbstick", "thumbstick_click"})) {
      return false;
    }
    // A new aim pose moves the grip with it unless the keyframe gives the grip too.
    if (v.contains("aim")) {
      if (!pose(v["aim"], path + ".aim", out.aim)) return false;
      if (!v.contains("grip")) out.grip = out.aim;
    }
    if (v.contains("grip") && !pose(v["grip"], path + ".grip", out.grip)) return false;
    if (v.contains("trigger") && !number_f(v["trigger"], path + ".trigger", 0.0, 1.0, out.trigger)) return false;
    if (v.contains("squeeze") && !number_f(v["squeeze"], path + ".squeeze", 0.0, 1.0, out.squeeze)) return false;
    if (v.contains(primary) && !boolean(v[primary], path + "." + primary, out.primary)) return false;
    if (v.contains(secondary) && !boolean(v[secondary], path + "." + secondary, out.secondary)) return false;
    if (v.contains("menu") && !boolean(v["menu"], path + ".menu", out.menu)) return false;
    if (v.contains("thumbstick_click") && !boolean(v["thumbstick_click"], path + ".thumbstick_click", out.thumbstick_click))
      return false;
    if (v.contains("thumbstick")) {
      float xy[2];
      if (!floats(v["thumbstick"], path + ".thumbstick", 2, -1.0, 1.0, xy)) return false;
      out.thumbstick = {xy[0], xy[1]};
    }
    return true;
  }
};

XrPosef make_pose(float x, float y, float z) {
  XrPosef p{};
  p.orientation.w = 1.0f;
  p.position = {x, y, z};
  return p;
}

}  // namespace

Script::Script() {
  const float quarter_pi = static_cast<float>(kHalfPi / 2.0);
  fov[0] = fov[1] = XrFovf{-quarter_pi, quarter_pi, quarter_pi, -quarter_pi};
  defaults_.head = make_pose(0.0f, 1.6f, 0.0f);
  // Controllers held in front of the body, pointing forward (-z).
  defaults_.left.aim = defaults_.left.grip = make_pose(-0.2f, 1.3f, -0.3f);
  defaults_.right.aim = defaults_.right.grip = make_pose(0.2f, 1.3f, -0.3f);
}

const TrackedState& Script::at(std::uint64_t frame) const {
  // The last keyframe at or before `frame`.
  auto it = std::upper_bound(keyframes.begin(), keyframes.end(), frame,
                             [](std::uint64_t f, const auto& k) { return f < k.first; });
  if (it == keyframes.begin()) return defaults_;
  return std::prev(it)->second;
}

Expected<Script> parse_script(const std::string& json_text, const std::string& source_name) {
  Reader r{source_name, {}};
  json doc;
  try {
    doc = json::parse(json_text);
  } catch (const json::parse_error& e) {
    return Error{source_name + ": not valid JSON (" + e.what() + ")"};
  }
  Script s;
  if (!r.only_keys(doc, "$", {"width", "height", "period_s", "ipd", "fov", "fov_right", "stage", "keyframes", "events",
                              "capture"}))
    return Error{r.error};
  double d = 0.0;
  if (doc.contains("width")) {
    if (!r.number(doc["width"], "$.width", 1, 4096, d) || d != std::floor(d)) {
      r.fail("$.width", "expected an integer in [1, 4096]");
      return Error{r.error};
    }
    s.width = static_cast<std::uint32_t>(d);
  }
  if (doc.contains("height")) {
    if (!r.number(doc["height"], "$.height", 1, 4096, d) || d != std::floor(d)) {
      r.fail("$.height", "expected an integer in [1, 4096]");
      return Error{r.error};
    }
    s.height = static_cast<std::uint32_t>(d);
  }
  if (doc.contains("period_s")) {
    if (!r.number(doc["period_s"], "$.period_s", 1e-4, 1.0, d)) return Error{r.error};
    s.period_ns = std::llround(d * 1e9);
  }
  if (doc.contains("ipd") && !r.number_f(doc["ipd"], "$.ipd", 0.0, 0.2, s.ipd)) return Error{r.error};
  if (doc.contains("fov")) {
    if (!r.fov(doc["fov"], "$.fov", s.fov[0])) return Error{r.error};
    s.fov[1] = s.fov[0];
  }
  if (doc.contains("fov_right") && !r.fov(doc["fov_right"], "$.fov_right", s.fov[1])) return Error{r.error};
  if (doc.contains("stage")) {
    float wh[2];
    if (!r.floats(doc["stage"], "$.stage", 2, 0.1, 1000.0, wh)) return Error{r.error};
    s.stage = {wh[0], wh[1]};
  }

  if (doc.contains("keyframes")) {
    const json& kfs = doc["keyframes"];
    if (!kfs.is_array()) {
      r.fail("$.keyframes", "expected an array");
      return Error{r.error};
    }
    TrackedState state = s.at(0);  // each keyframe starts from the previous one
    std::uint64_t last_frame = 0;
    for (std::size_t i = 0; i < kfs.size(); ++i) {
      const std::string path = "$.keyframes[" + std::to_string(i) + "]";
      const json& k = kfs[i];
      if (!r.only_keys(k, path, {"frame", "head", "left", "right"})) return Error{r.error};
      std::uint64_t frame = 0;
      if (!k.contains("frame")) {
        r.fail(path, "missing \"frame\"");
        return Error{r.error};
      }
      if (!r.frame_index(k["frame"], path + ".frame", frame)) return Error{r.error};
      if (i > 0 && frame <= last_frame) {
        r.fail(path + ".frame", "keyframes must be in increasing frame order");
        return Error{r.error};
      }
      last_frame = frame;
      if (k.contains("head") && !r.pose(k["head"], path + ".head", state.head)) return Error{r.error};
      if (k.contains("left") && !r.hand(k["left"], path + ".left", false, state.left)) return Error{r.error};
      if (k.contains("right") && !r.hand(k["right"], path + ".right", true, state.right)) return Error{r.error};
      s.keyframes.emplace_back(frame, state);
    }
  }

  if (doc.contains("events")) {
    const json& evs = doc["events"];
    if (!evs.is_array()) {
      r.fail("$.events", "expected an array");
      return Error{r.error};
    }
    for (std::size_t i = 0; i < evs.size(); ++i) {
      const std::string path = "$.events[" + std::to_string(i) + "]";
      const json& e = evs[i];
      if (!r.only_keys(e, path, {"frame", "type"})) return Error{r.error};
      ScriptEvent ev;
      if (!e.contains("frame") || !r.frame_index(e["frame"], path + ".frame", ev.frame)) {
        r.fail(path, "missing \"frame\"");
        return Error{r.error};
      }
      const std::string type = e.contains("type") && e["type"].is_string() ? e["type"].get<std::string>() : "";
      if (type == "loss") {
        ev.kind = ScriptEventKind::kLoss;
      } else if (type == "exit") {
        ev.kind = ScriptEventKind::kExit;
      } else {
        r.fail(path + ".type", "expected \"loss\" or \"exit\"");
        return Error{r.error};
      }
      s.events.push_back(ev);
    }
    std::stable_sort(s.events.begin(), s.events.end(), [](const auto& a, const auto& b) { return a.frame < b.frame; });
  }

  if (doc.contains("capture")) {
    const json& c = doc["capture"];
    if (c.is_string() && c.get<std::string>() == "all") {
      s.capture_all = true;
    } else if (c.is_array()) {
      for (std::size_t i = 0; i < c.size(); ++i) {
        std::uint64_t f = 0;
        if (!r.frame_index(c[i], "$.capture[" + std::to_string(i) + "]", f)) return Error{r.error};
        s.capture_frames.insert(f);
      }
    } else {
      r.fail("$.capture", "expected \"all\" or an array of frame indices");
      return Error{r.error};
    }
  }
  return s;
}

Expected<Script> load_script(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path.string() + ": cannot open the script (GAUSS_XR_HEADLESS_SCRIPT)"};
  std::ostringstream text;
  text << in.rdbuf();
  if (!in.good() && !in.eof()) return Error{path.string() + ": read error"};
  return parse_script(text.str(), path.string());
}

}  // namespace gauss::xr_headless
