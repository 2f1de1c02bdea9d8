#include "gauss/engine/rgbd_source.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <glm/gtc/quaternion.hpp>

namespace gauss {
namespace fs = std::filesystem;
namespace {

// Reads up to `count` numbers from a text file; error names the file and what is wrong.
Expected<std::vector<double>> read_numbers(const fs::path& path, std::size_t count) {
  std::ifstream in(path);
  if (!in) return Error{path.string() + ": cannot open"};
  std::vector<double> v;
  std::string tok;
  while (v.size() < count && in >> tok) {
    char* end = nullptr;
    const double x = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0' || !std::isfinite(x))
      return Error{path.string() + ": value " + std::to_string(v.size() + 1) + " ('" + tok + "') is not a finite number"};
    v.push_back(x);
  }
  if (v.size() != count)
    return Error{path.string() + ": expected " + std::to_string(count) + " numbers, found " + std::to_string(v.size())};
  return v;
}

// "timestamp rest..." lines, '#' comments skipped.
std::vector<std::pair<double, std::string>> read_tum_index(const fs::path& path) {
  std::vector<std::pair<double, std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double t = 0;
    std::string rest;
    if (!(s >> t)) continue;
    std::getline(s >> std::ws, rest);
    rows.emplace_back(t, rest);
  }
  std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return rows;
}

// Index of the row nearest in time to t, or -1 when none lies within max_dt seconds.
long nearest(const std::vector<std::pair<double, std::string>>& rows, double t, double max_dt) {
  auto it = std::lower_bound(rows.begin(), rows.end(), t, [](const auto& r, double x) { return r.first < x; });
  long best = -1;
  double best_dt = max_dt;
  for (auto c : {it, it == rows.begin() ? it : it - 1}) {
    if (c == rows.end()) continue;
    const double dt = std::abs(c->first - t);
    if (dt <= best_dt) {
      best_dt = dt;
      best = long(c - rows.begin());
    }
  }
  return best;
}

}  // namespace

Status read_intrinsics(const fs::path& path, double& fx, double& fy, double& cx, double& cy) {
  auto v = read_numbers(path, 9);
  if (!v) return v.error();
  const auto& k = *v;
  if (!(k[0] > 0) || !(k[4] > 0) || k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1)
    return Error{path.string() + ": not a pinhole intrinsics matrix (fx 0 cx / 0 fy cy / 0 0 1 with fx, fy > 0)"};
  fx = k[0];
  cx = k[2];
  fy = k[4];
  cy = k[5];
  return Ok{};
}

Expected<glm::dmat4> read_pose_4x4(const fs::path& path) {
  auto v = read_numbers(path, 16);
  if (!v) return v.error();
  glm::dmat4 m(1.0);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[c][r] = (*v)[std::size_t(r * 4 + c)];  // file is row-major
  return m;
}

Expected<RgbdFolderSource> RgbdFolderSource::open(const fs::path& folder) {
  if (!fs::is_directory(folder)) return Error{folder.string() + ": not a folder"};
  RgbdFolderSource src;
  if (fs::exists(folder / "depth.txt") && fs::exists(folder / "rgb.txt")) {
    src.layout_ = RgbdLayout::Tum;
    src.depth_scale_ = 5000.0;
    if (fs::exists(folder / "camera-intrinsics.txt")) {
      if (auto st = read_intrinsics(folder / "camera-intrinsics.txt", src.fx_, src.fy_, src.cx_, src.cy_); !st)
        return st.error();
    } else {
      src.fx_ = src.fy_ = 525.0;
      src.cx_ = 319.5;
      src.cy_ = 239.5;
    }
    if (!fs::exists(folder / "groundtruth.txt")) return Error{folder.string() + ": TUM layout without groundtruth.txt"};
    const auto depth = read_tum_index(folder / "depth.txt");
    const auto rgb = read_tum_index(folder / "rgb.txt");
    const auto gt = read_tum_index(folder / "groundtruth.txt");
    for (const auto& [t, rel] : depth) {
      const long ci = nearest(rgb, t, 0.02), pi = nearest(gt, t, 0.02);
      if (ci < 0 || pi < 0) continue;
      std::istringstream s(gt[std::size_t(pi)].second);
      double tx, ty, tz, qx, qy, qz, qw;
      if (!(s >> tx >> ty >> tz >> qx >> qy >> qz >> qw)) continue;
      FrameFiles f;
      f.name = (folder / rel).string();
      f.depth = folder / rel;
      f.colour = folder / rgb[std::size_t(ci)].second;
      const glm::dquat q(qw, qx, qy, qz);
      f.pose = glm::mat4_cast(glm::normalize(q));
      f.pose[3] = glm::dvec4(tx, ty, tz, 1.0);
      src.frames_.push_back(std::move(f));
    }
  } else {
    src.layout_ = RgbdLayout::ThreeDMatch;
    src.depth_scale_ = 1000.0;
    if (auto st = read_intrinsics(folder / "camera-intrinsics.txt", src.fx_, src.fy_, src.cx_, src.cy_); !st)
      return Error{folder.string() + ": neither a TUM folder (rgb.txt, depth.txt) nor a 3DMatch folder: " + st.message()};
    std::vector<fs::path> dirs{folder};
    for (const auto& e : fs::directory_iterator(folder))
      if (e.is_directory() && e.path().filename().string().rfind("seq-", 0) == 0) dirs.push_back(e.path());
    std::sort(dirs.begin() + 1, dirs.end());
    for (const auto& d : dirs) {
      std::vector<fs::path> depths;
      for (const auto& e : fs::directory_iterator(d)) {
        const std::string n = e.path().filename().string();
        if (n.rfind("frame-", 0) == 0 && n.size() > 10 && n.substr(n.size() - 10) == ".depth.png") depths.push_back(e.path());
      }
      std::sort(depths.begin(), depths.end());
      for (const auto& p : depths) {
        const std::string stem = p.string().substr(0, p.string().size() - 10);
        FrameFiles f;
        f.name = stem;
        f.depth = p;
        f.colour = stem + ".color.png";
        f.pose_file = stem + ".pose.txt";
        src.frames_.push_back(std::move(f));
      }
    }
  }
  if (src.frames_.empty()) return Error{folder.string() + ": no RGB-D frames found"};
  return src;
}

Expected<RgbdFrame> RgbdFolderSource::load(std::size_t i, Epoch epoch) const {
  if (i >= frames_.size()) return Error{"RGB-D frame index " + std::to_string(i) + " out of range"};
  const FrameFiles& ff = frames_[i];
  auto depth = read_png_u16(ff.depth);
  if (!depth) return Error{"RGB-D frame '" + ff.name + "': " + depth.message()};
  RgbdFrame f;
  f.name = ff.name;
  f.width = depth->width;
  f.height = depth->height;
  f.depth.resize(depth->pixels.size());
  for (std::size_t k = 0; k < f.depth.size(); ++k) f.depth[k] = float(double(depth->pixels[k]) / depth_scale_);
  if (fs::exists(ff.colour)) {
    auto colour = read_png_rgba8(ff.colour);
    if (!colour) return Error{"RGB-D frame '" + ff.name + "': " + colour.message()};
    f.colour = std::move(*colour);
  }
  if (!ff.pose_file.empty()) {
    auto pose = read_pose_4x4(ff.pose_file);
    if (!pose) return Error{"RGB-D frame '" + ff.name + "': " + pose.message()};
    f.camera_to_world = *pose;
  } else {
    f.camera_to_world = ff.pose;
  }
  f.fx = fx_;
  f.fy = fy_;
  f.cx = cx_;
  f.cy = cy_;
  f.epoch = epoch;
  return f;
}

}  // namespace gauss
