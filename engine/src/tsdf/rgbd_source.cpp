#include "gauss/engine/rgbd_source.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <glm/gtc/quaternion.hpp>

#include "rgbd_replica.h"

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

const char* rgbd_layout_name(RgbdLayout layout) {
  switch (layout) {
    case RgbdLayout::ThreeDMatch: return "3DMatch";
    case RgbdLayout::Tum: return "TUM";
    case RgbdLayout::Replica: return "Replica";
  }
  return "?";
}

Status RgbdFolderSource::list_tum(const fs::path& folder, RgbdFolderSource& src) {
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
  return Ok{};
}

Status RgbdFolderSource::list_replica(const fs::path& folder, RgbdFolderSource& src) {
  src.layout_ = RgbdLayout::Replica;
  fs::path params = folder / "cam_params.json";
  if (!fs::exists(params) && fs::exists(folder.parent_path() / "cam_params.json"))
    params = folder.parent_path() / "cam_params.json";
  if (!fs::exists(params))
    return Error{folder.string() +
                 ": Replica layout (traj.txt, results/) without cam_params.json here or in the parent folder"};
  auto cam = replica::read_cam_params(params);
  if (!cam) return cam.error();
  src.fx_ = cam->fx;
  src.fy_ = cam->fy;
  src.cx_ = cam->cx;
  src.cy_ = cam->cy;
  src.depth_scale_ = cam->depth_scale;
  src.width_ = cam->width;
  src.height_ = cam->height;
  const fs::path traj_path = folder / "traj.txt";
  auto traj = replica::read_trajectory(traj_path);
  if (!traj) return traj.error();

  // results/depthNNNNNN.png, by frame number N (not by name: the digits may vary in count).
  std::vector<std::pair<unsigned long, fs::path>> depths;
  for (const auto& e : fs::directory_iterator(folder / "results")) {
    const std::string n = e.path().filename().string();
    if (n.size() <= 9 || n.rfind("depth", 0) != 0 || n.substr(n.size() - 4) != ".png") continue;
    const std::string digits = n.substr(5, n.size() - 9);
    if (digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    depths.emplace_back(std::stoul(digits), e.path());
  }
  std::sort(depths.begin(), depths.end());
  for (const auto& [number, depth] : depths) {
    const std::string digits = depth.filename().string().substr(5, depth.filename().string().size() - 9);
    FrameFiles f;
    f.name = (folder / "results" / ("frame" + digits)).string();  // the messages then name the file
    f.depth = depth;
    f.colour = folder / "results" / ("frame" + digits + ".jpg");
    if (!fs::exists(f.colour) && fs::exists(folder / "results" / ("frame" + digits + ".png")))
      f.colour = folder / "results" / ("frame" + digits + ".png");
    if (number >= traj->size()) {
      f.pose_error = "no pose: " + traj_path.string() + " has " + std::to_string(traj->size()) +
                     " poses and frame " + std::to_string(number) + " needs line " + std::to_string(number + 1);
    } else {
      const auto& row = (*traj)[number];
      f.pose = row.camera_to_world;
      f.pose_error = row.error;
    }
    src.frames_.push_back(std::move(f));
  }
  return Ok{};
}

Status RgbdFolderSource::list_3dmatch(const fs::path& folder, RgbdFolderSource& src) {
  src.layout_ = RgbdLayout::ThreeDMatch;
  src.depth_scale_ = 1000.0;
  if (auto st = read_intrinsics(folder / "camera-intrinsics.txt", src.fx_, src.fy_, src.cx_, src.cy_); !st)
    return Error{folder.string() + ": neither a TUM folder (rgb.txt, depth.txt), a Replica folder (traj.txt, results/) "
                                   "nor a 3DMatch folder: " + st.message()};
  std::vector<fs::path> dirs{folder};
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_directory() && e.path().filename().string().rfind("seq-", 0) == 0) dirs.push_back(e.path());
  std::sort(dirs.begin() + 1, dirs.end());
  for (const auto& d : dirs) {
    std::vector<fs::path> depths;
    for (const auto& e : fs::directory_iterator(d)) {
      const std::string n = e.path().filename().string();
      if (n.rfind("frame-", 0) == 0 && n.size() > 10 && n.substr(n.size() - 10) == ".depth.png")
        depths.push_back(e.path());
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
  return Ok{};
}

Expected<RgbdFolderSource> RgbdFolderSource::open(const fs::path& folder) {
  if (!fs::is_directory(folder)) return Error{folder.string() + ": not a folder"};
  RgbdFolderSource src;
  Status listed = Ok{};
  try {  // directory listings report by exception (a folder unreadable midway); converted here
    if (fs::exists(folder / "depth.txt") && fs::exists(folder / "rgb.txt"))
      listed = list_tum(folder, src);
    else if (fs::exists(folder / "traj.txt") && fs::is_directory(folder / "results"))
      listed = list_replica(folder, src);
    else
      listed = list_3dmatch(folder, src);
  } catch (const fs::filesystem_error& e) {
    return Error{folder.string() + ": cannot list: " + e.what()};
  }
  if (!listed) return listed.error();
  if (src.frames_.empty())
    return Error{folder.string() + ": no RGB-D frames found (" + rgbd_layout_name(src.layout_) + " layout)"};
  return src;
}

Expected<glm::dmat4> RgbdFolderSource::frame_pose(std::size_t i) const {
  if (i >= frames_.size()) return Error{"RGB-D frame index " + std::to_string(i) + " out of range"};
  const FrameFiles& ff = frames_[i];
  if (!ff.pose_error.empty()) return Error{"RGB-D frame '" + ff.name + "': " + ff.pose_error};
  if (ff.pose_file.empty()) return ff.pose;
  auto pose = read_pose_4x4(ff.pose_file);
  if (!pose) return Error{"RGB-D frame '" + ff.name + "': " + pose.message()};
  return *pose;
}

Expected<RgbdFrame> RgbdFolderSource::load(std::size_t i, Epoch epoch) const {
  if (i >= frames_.size()) return Error{"RGB-D frame index " + std::to_string(i) + " out of range"};
  const FrameFiles& ff = frames_[i];
  const auto fail = [&](const std::string& what) { return Error{"RGB-D frame '" + ff.name + "': " + what}; };
  if (!ff.pose_error.empty()) return fail(ff.pose_error);
  auto depth = read_png_u16(ff.depth);
  if (!depth) return fail(depth.message());
  if (width_ != 0 && (depth->width != width_ || depth->height != height_))
    return fail(ff.depth.string() + ": depth image is " + std::to_string(depth->width) + "x" +
                std::to_string(depth->height) + " but cam_params.json says " + std::to_string(width_) + "x" +
                std::to_string(height_));
  RgbdFrame f;
  f.name = ff.name;
  f.width = depth->width;
  f.height = depth->height;
  f.depth.resize(depth->pixels.size());
  for (std::size_t k = 0; k < f.depth.size(); ++k) f.depth[k] = float(double(depth->pixels[k]) / depth_scale_);
  if (fs::exists(ff.colour)) {
    auto colour = read_image_rgba8(ff.colour);
    if (!colour) return fail(colour.message());
    if (colour->width != f.width || colour->height != f.height)
      return fail(ff.colour.string() + ": colour image is " + std::to_string(colour->width) + "x" +
                  std::to_string(colour->height) + " but its depth image is " + std::to_string(f.width) + "x" +
                  std::to_string(f.height));
    f.colour = std::move(*colour);
  }
  if (!ff.pose_file.empty()) {
    auto pose = read_pose_4x4(ff.pose_file);
    if (!pose) return fail(pose.message());
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
