#include "eval_scene.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "central_box.h"
#include "gauss/engine/lod_selector.h"
#include "gauss/engine/scene_source.h"
#include "gauss/engine/scene_up.h"

namespace gauss::eval_app {

namespace {

// Room `variant` as the options configure it (make_scene and EpochFeed produce the same room).
SyntheticSceneConfig room_config(const Options& o, int variant) {
  SyntheticSceneConfig sc;
  sc.variant = variant;
  sc.seed = o.seed;
  sc.target_gaussians = o.gaussians;
  sc.epochs = o.epochs;
  sc.surface_chunk = o.surface == "analytic";
  return sc;
}

// --labels / --objects for a scene file or snapshot folder.
SnapshotOptions snapshot_options(const Options& o) {
  SnapshotOptions so;
  if (!o.labels.empty()) so.labels = o.labels;
  if (!o.objects.empty()) so.objects_json = o.objects;
  return so;
}

// With LoD the host sends interior records, wider than any leaf: the codec's log-scale
// range reaches them (as gauss-host --lod on fits it). Both streams of --lod both share it,
// so they differ by their selection only.
Status widen_for_lod(const Options& o, EvalScene& s) {
  if (o.lod_on()) s.codec = fit_lod_codec_params(s.codec);
  return Ok{};
}

}  // namespace

Expected<EvalScene> make_scene(const Options& o, int variant) {
  auto synth = SyntheticScene::create(room_config(o, variant));
  if (!synth) return Error{"room " + std::to_string(variant) + ": " + synth.message()};
  EvalScene s;
  s.name = "room" + std::to_string(variant);
  s.variant = variant;
  s.synthetic = std::make_unique<SyntheticScene>(std::move(*synth));
  s.store = std::make_unique<SceneStore>();
  while (!s.synthetic->finished())
    if (auto st = s.synthetic->produce(*s.store); !st) return Error{s.name + ": " + st.message()};
  s.codec.sh_degree = s.store->sh_degree();
  s.codec.box.min = s.synthetic->room_min() - glm::vec3(0.5f);
  s.codec.box.max = s.synthetic->room_max() + glm::vec3(0.5f);
  if (auto st = widen_for_lod(o, s); !st) return st.error();
  s.appearance = s.store->size() - s.store->carrier_count();
  s.region_min = glm::dvec3(s.synthetic->room_min());
  s.region_max = glm::dvec3(s.synthetic->room_max());
  // Evenly spread over the trajectory (the centres of `cameras` equal parts), rescaled
  // to the evaluation size.
  const std::vector<Camera>& path = s.synthetic->trajectory();
  for (std::uint32_t k = 0; k < o.cameras; ++k) {
    s.cameras.push_back(
        resized_camera(path[static_cast<std::size_t>((k + 0.5) * path.size() / o.cameras)], o.width, o.height));
  }
  return s;
}

namespace {

// Two unit vectors spanning the plane perpendicular to `up` (the scene's horizon).
std::pair<glm::dvec3, glm::dvec3> horizon_basis(const glm::dvec3& up) {
  const glm::dvec3 ref = std::abs(up.x) < 0.9 ? glm::dvec3(1.0, 0.0, 0.0) : glm::dvec3(0.0, 0.0, 1.0);
  const glm::dvec3 a = glm::normalize(glm::cross(up, ref));
  return {a, glm::cross(a, up)};
}

}  // namespace

Expected<EvalScene> make_file_scene(const Options& o) {
  if (is_rgbd_capture(o.scene_file)) return make_capture_scene(o);
  EvalScene s;
  s.source = o.scene_file.string();
  s.name = o.scene_file.filename().string();
  // As gauss-host decides it, so the orbit cameras stand upright where a served scene does.
  const SceneUp up = choose_scene_up(o.up, o.scene_file);
  s.up = up.up;
  s.up_from = up.problem.empty() ? up.detail : up.detail + " (" + up.problem + ")";
  const SnapshotOptions so = snapshot_options(o);
  std::vector<std::string> log;
  auto keep = [&](const std::string& line) { log.push_back(line); };
  const bool folder = is_snapshot_folder(o.scene_file);
  auto source = folder ? open_snapshot_folder(o.scene_file, so, keep) : open_scene_file(o.scene_file, so, keep);
  if (!source) return source.error();
  s.store = std::make_unique<SceneStore>();
  // A file is one epoch; a folder gives one per snapshot, in order, until it has no more.
  for (bool more = true; more;) {
    auto committed = (*source)->next_epoch(*s.store);
    if (!committed) return Error{s.source + ": " + committed.message()};
    if (*committed && folder && ++s.snapshots == 1)  // as gauss-host fits a followed folder's codec
      s.codec = fit_live_codec_params(s.store->gaussians(), s.store->sh_degree());
    more = *committed && folder;
  }
  if (s.store->size() == 0) {
    std::string why = log.empty() ? "no Gaussians" : log.back();
    return Error{s.source + ": nothing to evaluate: " + why};
  }
  if (!folder) s.codec = fit_codec_params(s.store->gaussians(), s.store->sh_degree());
  if (auto st = widen_for_lod(o, s); !st) return st.error();
  s.appearance = s.store->size() - s.store->carrier_count();
  std::tie(s.region_min, s.region_max) = apps::central_box(appearance_gaussians(*s.store));
  const glm::dvec3 centre = 0.5 * (s.region_min + s.region_max);
  const double radius = std::max(1e-3, 0.5 * glm::length(s.region_max - s.region_min));
  const auto [a, b] = horizon_basis(s.up);
  const double elevation = 20.0 * 3.14159265358979323846 / 180.0, dist = 1.8 * radius;
  for (std::uint32_t k = 0; k < o.cameras; ++k) {
    const double az = 2.0 * 3.14159265358979323846 * k / o.cameras;
    const glm::dvec3 dir = std::cos(elevation) * (std::cos(az) * a + std::sin(az) * b) + std::sin(elevation) * s.up;
    s.cameras.push_back(look_camera(centre + dist * dir, centre, o.width, o.height, s.up));
  }
  return s;
}

Expected<EpochFeed> EpochFeed::open(const EvalScene& scene, const Options& o) {
  EpochFeed f;
  if (scene.synthetic) {
    auto synth = SyntheticScene::create(room_config(o, scene.variant));
    if (!synth) return synth.error();
    f.synthetic_.emplace(std::move(*synth));
    f.total_ = o.epochs;
    return f;
  }
  if (scene.capture) {
    auto source = open_rgbd_capture(o.scene_file, capture_options(o), [](const std::string&) {});
    if (!source) return source.error();
    f.folder_ = std::move(*source);
    f.total_ = scene.snapshots;
    return f;
  }
  if (scene.snapshots > 0) {
    auto source = open_snapshot_folder(o.scene_file, snapshot_options(o), [](const std::string&) {});
    if (!source) return source.error();
    f.folder_ = std::move(*source);
    f.total_ = scene.snapshots;
    return f;
  }
  return Error{scene.name + ": one epoch, no epochs to replay"};
}

Status EpochFeed::produce(SceneStore& store) {
  if (finished()) return Error{"EpochFeed: no epoch left"};
  if (synthetic_) {
    if (auto st = synthetic_->produce(store); !st) return st;
  } else {
    auto committed = folder_->next_epoch(store);
    if (!committed) return committed.error();
    if (!*committed) return Error{"epoch " + std::to_string(produced_ + 1) + " of " + std::to_string(total_) +
                                  " is gone from the folder"};
  }
  ++produced_;
  return Ok{};
}

bool EpochFeed::finished() const { return produced_ >= total_; }

Camera swayed(const Camera& a, double t) {
  constexpr double kTwoPi = 6.283185307179586;
  const glm::dmat4 cam_to_world = glm::inverse(a.world_to_camera);
  const glm::dvec3 right = glm::normalize(glm::dvec3(cam_to_world[0]));
  glm::dvec3 fwd = glm::dvec3(cam_to_world[2]);
  fwd.y = 0.0;
  fwd = glm::length(fwd) > 1e-6 ? glm::normalize(fwd) : glm::dvec3(0.0, 0.0, 1.0);
  const glm::dvec3 offset = 0.05 * std::sin(kTwoPi * 0.3 * t) * right + 0.03 * std::sin(kTwoPi * 0.45 * t) * fwd;
  const double yaw = 3.0 * 3.14159265358979323846 / 180.0 * std::sin(kTwoPi * 0.2 * t);
  const glm::dvec3 eye = glm::dvec3(cam_to_world[3]) + offset;
  const glm::dmat4 rot = glm::rotate(glm::dmat4(1.0), yaw, glm::dvec3(0.0, 1.0, 0.0));
  glm::dmat4 c2w = rot * cam_to_world;
  c2w[3] = glm::dvec4(eye, 1.0);
  Camera out = a;
  out.world_to_camera = glm::inverse(c2w);
  return out;
}

glm::dvec3 eye_of(const Camera& c) { return glm::dvec3(glm::inverse(c.world_to_camera)[3]); }
glm::dvec3 forward_of(const Camera& c) { return glm::normalize(glm::dvec3(glm::inverse(c.world_to_camera)[2])); }

Camera look_camera(const glm::dvec3& eye, const glm::dvec3& target, std::uint32_t width, std::uint32_t height,
                   const glm::dvec3& up) {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.75 * width;
  c.cx = 0.5 * width;
  c.cy = 0.5 * height;
  c.world_to_camera = glm::inverse(opencv_look_at(eye, target, up));
  return c;
}

ObjectViews object_views(const QueryResolution& r, const EvalScene& scene, std::uint32_t width, std::uint32_t height) {
  const glm::dvec3 centre = 0.5 * (glm::dvec3(r.extent_min) + glm::dvec3(r.extent_max));
  const double size = glm::length(glm::dvec3(r.extent_max) - glm::dvec3(r.extent_min));
  const glm::dvec3 scene_centre = 0.5 * (scene.region_min + scene.region_max);
  const glm::dvec3 eye0 = eye_of(scene.cameras.front());
  const double orbit = glm::length(eye0 - scene_centre);
  glm::dvec3 dir = eye0 - centre;
  dir = glm::length(dir) > 1e-9 ? glm::normalize(dir) : glm::normalize(eye0 - scene_centre);
  const glm::dvec3 near_eye = centre + std::max(1.5 * size, 0.2 * orbit) * dir;
  const glm::dvec3 far_eye = scene_centre + 1.5 * (eye0 - scene_centre);
  return {look_camera(near_eye, centre, width, height, scene.up), look_camera(far_eye, centre, width, height, scene.up)};
}

ObjectViews object_views(const QueryResolution& r, const SyntheticScene& scene, std::uint32_t width,
                         std::uint32_t height) {
  const glm::dvec3 lo(scene.room_min()), hi(scene.room_max());
  const glm::dvec3 centre = 0.5 * (glm::dvec3(r.extent_min) + glm::dvec3(r.extent_max));
  const double size = glm::length(glm::dvec3(r.extent_max) - glm::dvec3(r.extent_min));
  const std::vector<ObjectId> targets = r.ids();  // sorted
  auto inside = [&](glm::dvec3 p) { return glm::clamp(p, lo + 0.25, hi - 0.25); };
  // Target pixels the ground truth shows from `eye` (at 80 x 60: cheap, enough to rank).
  auto visible = [&](const glm::dvec3& eye) {
    const GroundTruthImage gt = scene.render_ground_truth(look_camera(eye, centre, 80, 60));
    return std::count_if(gt.object.begin(), gt.object.end(),
                         [&](ObjectId id) { return std::binary_search(targets.begin(), targets.end(), id); });
  };
  const double dist = std::max(1.0, 1.5 * size);
  glm::dvec3 near_eye = centre;
  std::ptrdiff_t best = -1;
  bool best_full = false;
  for (int k = 0; k < 8; ++k) {
    const double a = k * 0.25 * 3.14159265358979323846;
    glm::dvec3 eye = centre + dist * glm::dvec3(std::cos(a), 0.0, std::sin(a));
    eye.y = std::max(centre.y + 0.4, 1.2);
    eye = inside(eye);
    // A direction the walls cut short (the eye clamped well inside `dist`) would show a
    // close-up of part of the target: taken only when no direction keeps the distance.
    const bool full = glm::length(eye - centre) >= 0.75 * dist;
    const auto n = visible(eye);
    if ((full && !best_full) || (full == best_full && n > best)) {
      best = n;
      best_full = full;
      near_eye = eye;
    }
  }
  glm::dvec3 corners[4];
  std::ptrdiff_t seen[4], most = 0;
  for (int k = 0; k < 4; ++k) {
    corners[k] = inside(glm::dvec3((k & 1) ? hi.x : lo.x, hi.y - 0.4, (k & 2) ? hi.z : lo.z));
    seen[k] = visible(corners[k]);
    most = std::max(most, seen[k]);
  }
  glm::dvec3 far_eye = corners[0];
  double far_dist = -1.0;
  for (int k = 0; k < 4; ++k) {
    const double d = glm::length(corners[k] - centre);
    if (2 * seen[k] >= most && d > far_dist) {
      far_dist = d;
      far_eye = corners[k];
    }
  }
  return {look_camera(near_eye, centre, width, height), look_camera(far_eye, centre, width, height)};
}

std::vector<Gaussian> appearance_gaussians(const SceneStore& store) {
  std::vector<Gaussian> out;
  out.reserve(store.size());
  for (const Gaussian& g : store.gaussians())
    if (!g.carrier) out.push_back(g);
  return out;
}

}  // namespace gauss::eval_app
