// An RGB-D capture as a scene source: Gaussians seeded per pixel block, a fused surface.
#include "gauss/engine/rgbd_scene.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <optional>
#include <system_error>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/scene_up.h"
#include "gauss/engine/scene_view.h"

namespace gauss {

namespace fs = std::filesystem;

namespace {

// An earlier Gaussian explains the blocks its centre projects into and those within its
// in-plane sigma, up to this many blocks away (a huge close-up disc is not a wall).
constexpr std::int64_t kMaxCoverBlocks = 4;
// Seeds' in-plane sigma per block footprint (see seed()), and how much coarser than a new
// seed an earlier one may be and still explain a block (a wall first seen from 5 m away is
// seeded again from 2 m).
constexpr double kSigmaPerFootprint = 0.65;
constexpr double kCoarserSeed = 2.0;

bool finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// The frame's depth at pixel (x, y) when usable, else 0.
float usable_depth(const RgbdFrame& f, const RgbdSeedConfig& c, std::int64_t x, std::int64_t y) {
  if (x < 0 || y < 0 || x >= std::int64_t(f.width) || y >= std::int64_t(f.height)) return 0.0f;
  const float d = f.depth[std::size_t(y) * f.width + std::size_t(x)];
  return std::isfinite(d) && d >= c.min_depth && d <= c.max_depth ? d : 0.0f;
}

// A frame's back-projection of pixel centres into world space.
struct Backprojector {
  glm::dmat4 c2w;
  double fx, fy, cx, cy;
  glm::dvec3 world(double x, double y, double depth) const {
    const glm::dvec4 pc((x + 0.5 - cx) / fx * depth, (y + 0.5 - cy) / fy * depth, depth, 1.0);
    return glm::dvec3(c2w * pc);
  }
};

}  // namespace

Status validate(const RgbdSeedConfig& c) {
  if (c.stride < 1) return Error{"RGB-D seeding: stride must be at least 1"};
  if (!(c.depth_tolerance > 0.0f) || !std::isfinite(c.depth_tolerance))
    return Error{"RGB-D seeding: depth_tolerance must be positive and finite"};
  if (!(c.min_depth >= 0.0f) || !(c.max_depth > c.min_depth) || !std::isfinite(c.max_depth))
    return Error{"RGB-D seeding: depth range [" + std::to_string(c.min_depth) + ", " + std::to_string(c.max_depth) +
                 "] is empty or not finite"};
  if (!(c.opacity > 0.0f && c.opacity < 1.0f))
    return Error{"RGB-D seeding: opacity " + std::to_string(c.opacity) + " must lie in (0, 1)"};
  if (!(c.max_relative_step > 0.0f) || !std::isfinite(c.max_relative_step))
    return Error{"RGB-D seeding: max_relative_step must be positive and finite"};
  return Ok{};
}

Expected<std::vector<Gaussian>> RgbdSeeder::seed(const RgbdFrame& f) {
  if (auto s = validate(config_); !s) return s.error();
  const auto fail = [&](const std::string& what) { return Error{"RGB-D frame '" + f.name + "': " + what}; };
  const std::size_t pixels = std::size_t(f.width) * f.height;
  if (f.depth.size() != pixels) return fail("depth has " + std::to_string(f.depth.size()) + " values for " +
                                            std::to_string(f.width) + "x" + std::to_string(f.height));
  const bool has_colour = !f.colour.pixels.empty();
  if (has_colour && (f.colour.width != f.width || f.colour.height != f.height || f.colour.pixels.size() != pixels * 4))
    return fail("colour image is not the depth image's size");
  for (double v : {f.fx, f.fy})
    if (!(v > 0.0) || !std::isfinite(v)) return fail("focal length must be positive and finite");
  if (!std::isfinite(f.cx) || !std::isfinite(f.cy)) return fail("principal point is not finite");
  if (!finite(f.camera_to_world)) return fail("pose is not finite");

  const RgbdSeedConfig& c = config_;
  const Backprojector bp{f.camera_to_world, f.fx, f.fy, f.cx, f.cy};
  const glm::dvec3 eye(f.camera_to_world[3]);
  const double focal = 0.5 * (f.fx + f.fy);
  const std::int64_t s = c.stride;
  const std::int64_t half = s / 2;  // the block's centre pixel
  const std::int64_t bw = (std::int64_t(f.width) + s - 1) / s, bh = (std::int64_t(f.height) + s - 1) / s;

  // What the earlier frames' Gaussians show of each block: the nearest depth among those
  // whose centre lands in or near it (0: none).
  std::vector<float> explained(std::size_t(bw * bh), 0.0f);
  const glm::dmat4 w2c = glm::inverse(f.camera_to_world);
  for (const glm::vec4& g : seeds_) {
    const glm::dvec3 pc(w2c * glm::dvec4(g.x, g.y, g.z, 1.0));
    if (!(pc.z >= c.min_depth)) continue;
    // Seen from much closer now, the earlier disc is too coarse to stand for the surface.
    if (g.w > kCoarserSeed * kSigmaPerFootprint * pc.z * double(s) / focal) continue;
    const double u = f.fx * pc.x / pc.z + f.cx - 0.5, v = f.fy * pc.y / pc.z + f.cy - 0.5;
    const double reach = std::min(double(kMaxCoverBlocks), focal * g.w / pc.z / double(s));
    const std::int64_t x0 = std::int64_t(std::floor(u / s - reach)), x1 = std::int64_t(std::floor(u / s + reach));
    const std::int64_t y0 = std::int64_t(std::floor(v / s - reach)), y1 = std::int64_t(std::floor(v / s + reach));
    if (x1 < 0 || y1 < 0 || x0 >= bw || y0 >= bh) continue;
    for (std::int64_t y = std::max<std::int64_t>(y0, 0); y <= std::min(y1, bh - 1); ++y)
      for (std::int64_t x = std::max<std::int64_t>(x0, 0); x <= std::min(x1, bw - 1); ++x) {
        float& e = explained[std::size_t(y * bw + x)];
        if (e == 0.0f || pc.z < e) e = float(pc.z);
      }
  }

  std::vector<Gaussian> out;
  for (std::int64_t by = 0; by * s < std::int64_t(f.height); ++by)
    for (std::int64_t bx = 0; bx * s < std::int64_t(f.width); ++bx) {
      const std::int64_t x = std::min(bx * s + half, std::int64_t(f.width) - 1);
      const std::int64_t y = std::min(by * s + half, std::int64_t(f.height) - 1);
      const float d = usable_depth(f, c, x, y);
      if (d == 0.0f) continue;
      if (const float e = explained[std::size_t(by * bw + bx)]; e != 0.0f && std::abs(e - d) <= c.depth_tolerance * d)
        continue;  // an earlier frame's Gaussian already shows this surface here
      const glm::dvec3 p = bp.world(double(x), double(y), d);
      // Along each image axis, the neighbouring block on the side without a depth edge.
      glm::dvec3 axis[2];
      bool seen_axis[2] = {false, false}, lone = false;
      for (int a = 0; a < 2 && !lone; ++a) {
        double best_step = 0.0;
        for (int side : {+1, -1}) {
          const std::int64_t nx = a == 0 ? x + side * s : x, ny = a == 1 ? y + side * s : y;
          const float nd = usable_depth(f, c, nx, ny);
          if (nd == 0.0f) continue;
          const double step = std::abs(double(nd) - d);
          if (step > c.max_relative_step * d) continue;
          if (!seen_axis[a] || step < best_step) {
            axis[a] = double(side) * (bp.world(double(nx), double(ny), nd) - p);
            best_step = step;
            seen_axis[a] = true;
          }
        }
        // Neighbours on this axis exist but all across an edge: a flying or lone point.
        if (!seen_axis[a]) {
          bool any = false;
          for (int side : {+1, -1})
            any |= usable_depth(f, c, a == 0 ? x + side * s : x, a == 1 ? y + side * s : y) != 0.0f;
          lone = any;
        }
      }
      if (lone) continue;
      const glm::dvec3 to_eye = glm::normalize(eye - p);
      glm::dvec3 normal = to_eye;  // a block at the data's border faces the camera
      if (seen_axis[0] && seen_axis[1]) {
        const glm::dvec3 n = glm::cross(axis[0], axis[1]);
        if (glm::length(n) > 0.0) normal = glm::normalize(n);
        if (glm::dot(normal, to_eye) < 0.0) normal = -normal;
      }


      // The block's mean colour over its pixels with usable depth (grey without colour).
      glm::dvec3 colour(0.5);
      if (has_colour) {
        glm::dvec3 sum(0.0);
        int n = 0;
        for (std::int64_t yy = by * s; yy < std::min((by + 1) * s, std::int64_t(f.height)); ++yy)
          for (std::int64_t xx = bx * s; xx < std::min((bx + 1) * s, std::int64_t(f.width)); ++xx) {
            if (usable_depth(f, c, xx, yy) == 0.0f) continue;
            const std::uint8_t* px = &f.colour.pixels[(std::size_t(yy) * f.width + std::size_t(xx)) * 4];
            sum += glm::dvec3(px[0], px[1], px[2]) / 255.0;
            ++n;
          }
        colour = sum / double(n);  // n >= 1: the centre pixel has usable depth
      }
      // Flat on the surface: sigma = 0.65 x the block's footprint, a tenth of that along the
      // normal, as the synthetic room's surfels: no see-through gaps between neighbours at
      // this opacity.
      const double sigma = kSigmaPerFootprint * double(d) * double(s) / focal;
      const glm::dvec3 ref = std::abs(normal.z) < 0.9 ? glm::dvec3(0.0, 0.0, 1.0) : glm::dvec3(1.0, 0.0, 0.0);
      const glm::dvec3 tangent = glm::normalize(glm::cross(ref, normal));
      const glm::dvec3 bitangent = glm::cross(normal, tangent);
      const glm::quat rot = glm::normalize(glm::quat_cast(glm::mat3(glm::vec3(tangent), glm::vec3(bitangent),
                                                                    glm::vec3(normal))));
      Gaussian g;
      g.position = glm::vec3(p);
      g.log_scale = glm::vec3(float(std::log(sigma)), float(std::log(sigma)), float(std::log(0.1 * sigma)));
      g.rotation = glm::vec4(rot.w, rot.x, rot.y, rot.z);
      g.opacity_logit = std::log(c.opacity / (1.0f - c.opacity));
      g.sh_dc = (glm::vec3(colour) - 0.5f) / float(kShC0);
      g.support = 1;
      out.push_back(g);
      seeds_.emplace_back(g.position, float(sigma));  // `explained` above is already built
    }
  return out;
}

bool is_rgbd_capture(const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return false;
  return fs::is_regular_file(folder / "camera-intrinsics.txt", ec) ||
         (fs::is_regular_file(folder / "rgb.txt", ec) && fs::is_regular_file(folder / "depth.txt", ec)) ||
         (fs::is_regular_file(folder / "traj.txt", ec) && fs::is_directory(folder / "results", ec));
}

namespace {

class RgbdCaptureSource final : public SceneSource {
 public:
  RgbdCaptureSource(fs::path folder, RgbdFolderSource capture, const RgbdSceneOptions& options,
                    std::optional<TsdfVolume> surface, SourceLog log)
      : SceneSource(std::move(log)),
        folder_(std::move(folder)),
        capture_(std::move(capture)),
        options_(options),
        seeder_(options.seed),
        surface_(std::move(surface)) {}

  Expected<bool> next_epoch(SceneStore& store) override {
    if (store.in_epoch()) return Error{"RGB-D capture " + folder_.string() + ": the store has an open epoch"};
    while (next_ < capture_.frame_count()) {
      const std::size_t i = next_++;
      auto committed = add_frame(store, i);
      // Once an epoch is open the store cannot take the frame back: that is not a skip.
      if (!committed && store.in_epoch()) return committed.error();
      if (!committed) {
        report(committed.message() + " (frame skipped)");  // the message names the frame
        continue;
      }
      if (*committed) {
        ++epochs_;
        return true;
      }
    }
    if (epochs_ == 0 && !said_empty_) {
      said_empty_ = true;
      return Error{"RGB-D capture " + folder_.string() + ": none of its " + std::to_string(capture_.frame_count()) +
                   " frames gave a Gaussian or a surface"};
    }
    return false;
  }
  double epoch_period_s() const override { return 1.0 / options_.rate_hz; }
  std::string describe() const override {
    return "RGB-D capture " + folder_.string() + " (" + rgbd_layout_name(capture_.layout()) + ", " +
           std::to_string(capture_.frame_count()) + " frames, a Gaussian per " + std::to_string(options_.seed.stride) +
           "x" + std::to_string(options_.seed.stride) + " pixels" + (surface_ ? ", fused surface" : "") + ")";
  }

 private:
  // Seeds and fuses frame i; commits an epoch when either changed the scene.
  Expected<bool> add_frame(SceneStore& store, std::size_t i) {
    auto frame = capture_.load(i, Epoch(static_cast<std::uint64_t>(store.epoch()) + 1));
    if (!frame) return frame.error();
    // Both steps run before the epoch opens, so a bad frame leaves the store as it was. The
    // surface goes first: a frame it refuses changes nothing, while the seeder remembers its
    // Gaussians (it refuses only before remembering any).
    std::vector<SurfaceEdit> edits;
    if (surface_) {
      if (auto s = surface_->integrate(*frame); !s) return s.error();
      edits = surface_->extract_changed();
    }
    std::vector<Gaussian> seeded;
    if (auto g = seeder_.seed(*frame))
      seeded = std::move(*g);
    else if (edits.empty())
      return g.error();
    else  // the surface it changed still goes out
      report(g.message() + " (its surface kept, no Gaussians seeded)");
    for (const Gaussian& g : seeded)
      if (auto v = SceneStore::validate(g, store.sh_degree()); !v) {
        report("RGB-D frame '" + frame->name + "': a seeded Gaussian is unusable (" + v.message() +
               "): its Gaussians are dropped");
        seeded.clear();
        break;
      }
    if (seeded.empty() && edits.empty()) return false;
    Status s = store.begin_next_epoch();
    for (std::size_t k = 0; s && k < seeded.size(); ++k) {
      seeded[k].id = store.allocate_id();
      s = store.insert(seeded[k]);
    }
    if (s) s = apply_surface_edits(store, edits);
    if (s) s = store.commit_epoch();
    if (!s) return Error{"RGB-D frame '" + frame->name + "': committing its epoch: " + s.message()};
    return true;
  }

  fs::path folder_;
  RgbdFolderSource capture_;
  RgbdSceneOptions options_;
  RgbdSeeder seeder_;
  std::optional<TsdfVolume> surface_;
  std::size_t next_{0};
  int epochs_{0};
  bool said_empty_{false};
};

}  // namespace

Expected<std::unique_ptr<SceneSource>> open_rgbd_capture(const fs::path& folder, const RgbdSceneOptions& options,
                                                         SourceLog log) {
  if (!(options.rate_hz > 0.0) || !std::isfinite(options.rate_hz))
    return Error{"RGB-D capture: rate_hz must be positive and finite"};
  if (auto s = validate(options.seed); !s) return s.error();
  auto capture = RgbdFolderSource::open(folder);
  if (!capture) return capture.error();
  std::optional<TsdfVolume> surface;
  if (options.surface) {
    auto v = TsdfVolume::create(*options.surface);
    if (!v) return Error{"RGB-D capture surface: " + v.message()};
    surface.emplace(std::move(*v));
  }
  return std::unique_ptr<SceneSource>(std::make_unique<RgbdCaptureSource>(folder, std::move(*capture), options,
                                                                          std::move(surface), std::move(log)));
}

Expected<CaptureFit> fit_capture(const fs::path& folder, const RgbdSceneOptions& options) {
  RgbdSceneOptions dry = options;
  dry.surface.reset();  // the seeding alone decides the Gaussians
  auto source = open_rgbd_capture(folder, dry, [](const std::string&) {});
  if (!source) return source.error();
  SceneStore store;
  for (;;) {
    auto committed = (*source)->next_epoch(store);
    if (!committed) return committed.error();
    if (!*committed) break;
  }
  if (store.size() == 0) return Error{"RGB-D capture " + folder.string() + ": no frame seeds a Gaussian"};
  CaptureFit fit;
  fit.params = fit_codec_params(store.gaussians(), store.sh_degree());
  // The cameras: their axes give the capture's up (capture_up), their centres its side.
  auto frames = RgbdFolderSource::open(folder);
  if (!frames) return frames.error();
  std::vector<CameraAxes> axes;
  glm::dvec3 position_sum(0.0);
  for (std::size_t i = 0; i < frames->frame_count(); ++i) {
    auto pose = frames->frame_pose(i);
    if (!pose) continue;
    const glm::dvec3 right((*pose)[0]), down((*pose)[1]), at((*pose)[3]);
    if (!std::isfinite(right.x + right.y + right.z + down.x + down.y + down.z + at.x + at.y + at.z)) continue;
    axes.push_back(CameraAxes{right, down});
    position_sum += at;
  }
  std::optional<glm::dvec3> seen_from;
  if (!axes.empty()) seen_from = position_sum / double(axes.size());
  // No agreed up (no usable pose, or ups that cancel): capture_view takes zero as +y.
  const auto up = capture_up(axes);
  fit.view = capture_view(store.gaussians(), up ? *up : glm::dvec3(0.0), seen_from);
  return fit;
}

}  // namespace gauss
