// An RGB-D capture as an evaluation scene: the scene gauss-host serves from it, evaluated
// from the capture's own cameras with its own frames as the ground truth.
#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "central_box.h"
#include "eval_scene.h"
#include "gauss/engine/rgbd_source.h"

namespace gauss::eval_app {

RgbdSceneOptions capture_options(const Options& o) {
  RgbdSceneOptions r;
  r.seed.stride = o.rgbd_stride;
  if (o.surface == "fused")
    r.surface->voxel_size = static_cast<float>(kCaptureSurfaceVoxel);
  else
    r.surface.reset();
  return r;
}

namespace {

// `frame` box-filtered down by `factor` as ground truth: colour the mean of each block,
// depth its mean where every pixel of the block has depth (else 0: not counted).
GroundTruthImage downsampled_truth(const RgbdFrame& f, std::uint32_t factor) {
  GroundTruthImage gt;
  const std::uint32_t w = f.width / factor, h = f.height / factor;
  gt.colour.width = w;
  gt.colour.height = h;
  gt.colour.pixels.assign(std::size_t(w) * h * 4, 255);
  gt.depth.assign(std::size_t(w) * h, 0.0f);
  gt.object.assign(std::size_t(w) * h, kNoObject);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      double rgb[3] = {0, 0, 0}, depth = 0.0;
      bool full = true;
      for (std::uint32_t j = 0; j < factor; ++j)
        for (std::uint32_t i = 0; i < factor; ++i) {
          const std::size_t k = std::size_t(y * factor + j) * f.width + (x * factor + i);
          for (int c = 0; c < 3; ++c) rgb[c] += f.colour.pixels[4 * k + c];
          const float d = f.depth[k];
          full = full && std::isfinite(d) && d > 0.0f;
          depth += full ? d : 0.0;
        }
      const std::size_t o = std::size_t(y) * w + x;
      const double n = double(factor) * factor;
      for (int c = 0; c < 3; ++c) gt.colour.pixels[4 * o + c] = std::uint8_t(std::lround(rgb[c] / n));
      gt.depth[o] = full ? float(depth / n) : 0.0f;
    }
  return gt;
}

bool same_camera(const Camera& a, const Camera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx &&
         a.cy == b.cy && a.world_to_camera == b.world_to_camera;
}

}  // namespace

Expected<EvalScene> make_capture_scene(const Options& o) {
  EvalScene s;
  s.source = o.scene_file.string();
  s.name = o.scene_file.filename().string();
  s.capture = true;
  auto source = open_rgbd_capture(o.scene_file, capture_options(o), [](const std::string&) {});
  if (!source) return source.error();
  s.store = std::make_unique<SceneStore>();
  for (;;) {
    auto committed = (*source)->next_epoch(*s.store);
    if (!committed) return Error{s.source + ": " + committed.message()};
    if (!*committed) break;
    ++s.snapshots;
  }
  auto fit = fit_capture(o.scene_file, capture_options(o));  // the codec and view gauss-host announces
  if (!fit) return Error{s.source + ": " + fit.message()};
  s.codec = fit->params;
  s.up = fit->view.up;
  s.up_from = "the capture's cameras";
  s.appearance = s.store->size() - s.store->carrier_count();
  std::tie(s.region_min, s.region_max) = apps::central_box(appearance_gaussians(*s.store));

  // The frames that load, and from them the cameras, evenly spread as a room's trajectory.
  auto capture = RgbdFolderSource::open(o.scene_file);
  if (!capture) return capture.error();
  std::vector<std::size_t> usable;
  for (std::size_t i = 0; i < capture->frame_count(); ++i)
    if (capture->load(i, Epoch(0))) usable.push_back(i);
  const std::size_t count = std::min<std::size_t>(o.cameras, usable.size());
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = usable[static_cast<std::size_t>((k + 0.5) * usable.size() / count)];
    auto frame = capture->load(i, Epoch(0));
    if (!frame) return Error{s.source + ": " + frame.message()};
    if (frame->colour.pixels.empty())
      return Error{s.source + ": frame " + frame->name + " has no colour image: no ground truth to evaluate against"};
    const std::uint32_t factor = frame->width / o.width;
    if (factor == 0 || frame->width != factor * o.width || frame->height != factor * o.height)
      return Error{"--size " + std::to_string(o.width) + "x" + std::to_string(o.height) + ": " + s.source +
                   ": its frames are " + std::to_string(frame->width) + "x" + std::to_string(frame->height) +
                   "; the evaluation size must divide them by one whole factor (e.g. " +
                   std::to_string(frame->width / 2) + "x" + std::to_string(frame->height / 2) + ")"};
    s.cameras.push_back(resized_camera(frame_camera(*frame), o.width, o.height));
    s.capture_truth.push_back(downsampled_truth(*frame, factor));
    s.capture_frames.push_back(frame->name);
  }
  if (s.cameras.empty()) return Error{s.source + ": no frame of the capture loads"};
  return s;
}

std::optional<GroundTruthImage> ground_truth(const EvalScene& scene, const Camera& camera) {
  if (scene.synthetic) return scene.synthetic->render_ground_truth(camera);
  for (std::size_t k = 0; k < scene.capture_truth.size(); ++k)
    if (same_camera(scene.cameras[k], camera)) return scene.capture_truth[k];
  return std::nullopt;
}

}  // namespace gauss::eval_app
