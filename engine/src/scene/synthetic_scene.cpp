#include "gauss/engine/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include "prng.h"
#include "synthetic_room.h"

namespace gauss {
namespace {

using scene::hash;
using scene::kPi;
using scene::mix64;
using scene::signed_unit3;
using scene::unit;

constexpr std::int16_t kNever = 32767;

// Stream tags so that independent random quantities never share a key.
enum Stream : std::uint64_t {
  kPatchJitter = 1, kNoise = 2, kColourNoise = 3, kOpacity = 4, kPrune = 5, kCarrier = 6, kPhase = 7,
};

// One point of the analytic surface that a Gaussian covers when observed.
struct Sample {
  glm::vec3 position;
  glm::vec3 normal;
  glm::vec3 tangent;
  glm::vec3 colour;    // shaded surface colour, what the converged SH0 carries
  glm::vec2 spacing;   // distance to the neighbours along tangent / bitangent (metres)
  ObjectId object;
  std::int16_t first_seen;  // first epoch whose cameras look at it (kNever: none)
};

struct Carrier {
  glm::vec3 position;
  float size;
  ObjectId object;
};

float logit(float p) { return std::log(p / (1.0f - p)); }

// Splits `total` over weights by the largest remainder (deterministic, sums exactly).
std::vector<std::size_t> apportion(const std::vector<double>& weights, std::size_t total) {
  double sum = 0.0;
  for (double w : weights) sum += w;
  std::vector<std::size_t> out(weights.size(), 0);
  std::vector<std::pair<double, std::size_t>> rest;
  std::size_t given = 0;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    const double exact = sum > 0.0 ? weights[i] / sum * double(total) : 0.0;
    out[i] = static_cast<std::size_t>(std::floor(exact));
    given += out[i];
    rest.emplace_back(exact - std::floor(exact), i);
  }
  std::sort(rest.begin(), rest.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  for (std::size_t k = 0; given < total && k < rest.size(); ++k, ++given) ++out[rest[k].second];
  return out;
}

Camera look_camera(const glm::vec3& pos, const glm::vec3& forward_in, const SyntheticSceneConfig& c) {
  const glm::dvec3 f = glm::normalize(glm::dvec3(forward_in));
  const glm::dvec3 right = glm::normalize(glm::cross(f, glm::dvec3(0.0, 1.0, 0.0)));
  const glm::dvec3 down = glm::cross(f, right);
  Camera cam;
  cam.width = c.image_width;
  cam.height = c.image_height;
  cam.fx = cam.fy = c.focal_px;
  cam.cx = 0.5 * c.image_width;
  cam.cy = 0.5 * c.image_height;
  glm::dmat4 m(1.0);
  for (int k = 0; k < 3; ++k) {  // rows = camera axes in world coordinates
    m[k][0] = right[k];
    m[k][1] = down[k];
    m[k][2] = f[k];
  }
  const glm::dvec3 p(pos);
  m[3][0] = -glm::dot(right, p);
  m[3][1] = -glm::dot(down, p);
  m[3][2] = -glm::dot(f, p);
  cam.world_to_camera = m;
  return cam;
}

// Camera-space test used for "where the camera has looked": in front, inside the image,
// within range, and the surface faces the camera.
struct ViewTest {
  glm::mat3 rot;
  glm::vec3 trans;
  glm::vec3 eye;
  float fx, fy, cx, cy, w, h;
  bool sees(const glm::vec3& p, const glm::vec3& n) const {
    const glm::vec3 q = rot * p + trans;
    if (q.z < 0.1f || q.z > 12.0f) return false;
    const float u = fx * q.x / q.z + cx, v = fy * q.y / q.z + cy;
    if (u < 0.0f || u > w || v < 0.0f || v > h) return false;
    return glm::dot(n, eye - p) > 0.0f;
  }
};

ViewTest view_test(const Camera& cam) {
  ViewTest t{};
  const glm::mat4 m(cam.world_to_camera);
  t.rot = glm::mat3(m);
  t.trans = glm::vec3(m[3]);
  t.eye = -glm::transpose(t.rot) * t.trans;
  t.fx = float(cam.fx);
  t.fy = float(cam.fy);
  t.cx = float(cam.cx);
  t.cy = float(cam.cy);
  t.w = float(cam.width);
  t.h = float(cam.height);
  return t;
}

}  // namespace

struct SyntheticScene::Impl {
  SyntheticSceneConfig config;
  scene::Room room;
  std::vector<Sample> samples;
  std::vector<std::uint64_t> live_id;  // 0 = not live
  std::vector<std::int16_t> birth;
  std::vector<Carrier> carriers;
  std::vector<std::int16_t> object_first_seen;  // per room.objects index
  std::vector<std::size_t> object_samples;      // observed samples per object (for observation quality)
  std::vector<std::vector<std::size_t>> object_seen_per_epoch;  // [object][epoch]: samples first seen then
  std::vector<SyntheticObjectInfo> objects;
  std::vector<Camera> trajectory;
  int produced{0};
  std::uint64_t next_id{1};

  void build_samples(std::size_t count);
  void build_trajectory();
  void observe();
  Gaussian gaussian_of(std::size_t i, int epoch) const;
  Gaussian carrier_of(std::size_t k) const;
};

void SyntheticScene::Impl::build_samples(std::size_t count) {
  const std::vector<scene::Patch> patches = scene::surface_patches(room);
  std::vector<double> areas;
  for (const auto& p : patches) areas.push_back(p.area);
  const std::vector<std::size_t> counts = apportion(areas, count);
  samples.clear();
  samples.reserve(count);
  for (std::size_t pi = 0; pi < patches.size(); ++pi) {
    const scene::Patch& patch = patches[pi];
    const std::size_t n = counts[pi];
    if (n == 0) continue;
    const scene::Primitive& prim = room.primitives[static_cast<std::size_t>(patch.primitive)];
    const std::uint64_t pkey = hash(config.seed, kPatchJitter, pi);
    const auto emit = [&](glm::vec2 uv, glm::vec2 spacing) {
      const scene::SurfacePoint sp = scene::sample_patch(patch, uv);
      Sample s;
      s.position = sp.position;
      s.normal = sp.normal;
      s.tangent = sp.tangent;
      s.colour = scene::surface_colour(prim, sp.position, sp.normal);
      s.spacing = spacing;
      s.object = prim.object;
      s.first_seen = kNever;
      samples.push_back(s);
    };
    const float iso = std::sqrt(patch.area / float(n));
    if (patch.kind == scene::Patch::Kind::Rect || patch.kind == scene::Patch::Kind::CylinderSide) {
      // Rows matched to the aspect ratio, points spread evenly along each row with a small
      // jitter: covers the patch without holes for any count.
      const float lu = patch.kind == scene::Patch::Kind::Rect ? glm::length(patch.axis_u) : 2.0f * kPi * patch.radius;
      const float lv = patch.kind == scene::Patch::Kind::Rect ? glm::length(patch.axis_v) : 2.0f * patch.normal.y;
      const std::size_t rows = std::clamp<std::size_t>(
          static_cast<std::size_t>(std::lround(std::sqrt(double(n) * lv / std::max(lu, 1e-6f)))), 1, n);
      std::size_t k = 0;
      for (std::size_t r = 0; r < rows; ++r) {
        const std::size_t in_row = n / rows + (r < n % rows ? 1 : 0);
        const float row_offset = unit(hash(pkey, r));  // staggers rows so columns do not line up
        for (std::size_t c = 0; c < in_row; ++c, ++k) {
          const std::uint64_t key = hash(pkey, r, c);
          float u = (float(c) + 0.5f + 0.3f * scene::signed_unit(mix64(key))) / float(in_row);
          if (patch.kind == scene::Patch::Kind::CylinderSide) u = u + row_offset / float(in_row) - std::floor(u + row_offset / float(in_row));
          const float v = (float(r) + 0.5f + 0.3f * scene::signed_unit(mix64(key ^ 0xABCD))) / float(rows);
          emit({std::clamp(u, 0.0f, 1.0f), std::clamp(v, 0.0f, 1.0f)}, {lu / float(in_row), lv / float(rows)});
        }
      }
    } else if (patch.kind == scene::Patch::Kind::Disk) {
      // Sunflower (Vogel) spiral: near-uniform for any count.
      for (std::size_t k = 0; k < n; ++k) {
        const float ga = 0.38196601125f;  // golden-angle fraction of a turn
        emit({(float(k) + 0.5f) / float(n), float(k) * ga - std::floor(float(k) * ga)}, {iso, iso});
      }
    } else {
      // Fibonacci sphere: equal-area bands in z with golden-ratio longitude steps.
      const float turn = unit(pkey);
      for (std::size_t k = 0; k < n; ++k) {
        const float lon = float(k) * 0.61803398875f + turn;
        emit({(float(k) + 0.5f) / float(n), lon - std::floor(lon)}, {iso, iso});
      }
    }
  }
}

void SyntheticScene::Impl::build_trajectory() {
  // An orbit inside the room at standing eye height, looking across the room with a slow
  // sideways sweep and a downward tilt; the seed rotates where the orbit starts.
  const int n = config.epochs * config.cameras_per_epoch;
  const glm::vec3 centre = 0.5f * (room.min + room.max);
  const glm::vec3 half = 0.5f * (room.max - room.min);
  const float phase = 2.0f * kPi * unit(hash(config.seed, kPhase));
  trajectory.reserve(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) {
    const float t = (float(j) + 0.5f) / float(n);
    const float theta = phase + 2.0f * kPi * t;
    const glm::vec3 pos(centre.x + 0.62f * half.x * std::cos(theta), 1.45f + 0.1f * std::sin(3.0f * theta),
                        centre.z + 0.62f * half.z * std::sin(theta));
    const glm::vec3 to_centre = glm::normalize(glm::vec3(centre.x - pos.x, 0.0f, centre.z - pos.z));
    const float sweep = 0.6f * std::sin(6.0f * kPi * t);
    const float c = std::cos(sweep), s = std::sin(sweep);
    const glm::vec3 h(c * to_centre.x + s * to_centre.z, 0.0f, -s * to_centre.x + c * to_centre.z);
    // Mostly looking down at furniture, now and then up far enough to see the ceiling.
    const float pitch = -0.25f + 0.3f * std::sin(10.0f * kPi * t);
    trajectory.push_back(look_camera(pos, std::cos(pitch) * h + glm::vec3(0.0f, std::sin(pitch), 0.0f), config));
  }
}

void SyntheticScene::Impl::observe() {
  std::vector<ViewTest> tests;
  for (const Camera& cam : trajectory) tests.push_back(view_test(cam));
  const int k = config.cameras_per_epoch;
  object_first_seen.assign(room.objects.size(), kNever);
  object_samples.assign(room.objects.size(), 0);
  object_seen_per_epoch.assign(room.objects.size(), std::vector<std::size_t>(static_cast<std::size_t>(config.epochs), 0));
  for (Sample& s : samples) {
    for (std::size_t c = 0; c < tests.size(); ++c)
      if (tests[c].sees(s.position, s.normal)) {
        s.first_seen = static_cast<std::int16_t>(static_cast<int>(c) / k);
        break;
      }
    if (s.object != kNoObject) {
      const auto o = static_cast<std::size_t>(to_underlying(s.object) - 1);
      object_first_seen[o] = std::min(object_first_seen[o], s.first_seen);
      if (s.first_seen != kNever) {
        ++object_samples[o];
        ++object_seen_per_epoch[o][static_cast<std::size_t>(s.first_seen)];
      }
    }
  }
}

Gaussian SyntheticScene::Impl::gaussian_of(std::size_t i, int epoch) const {
  const Sample& s = samples[i];
  const int age = epoch - birth[i];
  const int K = config.converge_epochs;
  // Remaining noise: 1 at birth, exactly 0 from age K on (so converged Gaussians stop changing).
  const float f = age >= K ? 0.0f : std::pow(1.0f - float(age) / float(K), 2.0f);
  const std::uint64_t key = hash(config.seed, kNoise, i, static_cast<std::uint64_t>(birth[i]));
  const glm::vec3 bitangent = glm::cross(s.normal, s.tangent);
  const glm::vec3 j = signed_unit3(key);
  // Young Gaussians sit off their final place by up to 0.3 spacing (capped at 4.5 cm, so a
  // lone Gaussian on a long thin strip does not wander off the object).
  const float ju = 0.3f * std::min(s.spacing.x, 0.15f), jv = 0.3f * std::min(s.spacing.y, 0.15f);
  const float jn = 0.3f * std::min(std::min(s.spacing.x, s.spacing.y), 0.15f);
  Gaussian g;
  g.id = GaussianId{live_id[i]};
  g.object = s.object;
  g.position = s.position + f * (ju * j.x * s.tangent + jv * j.y * bitangent + jn * j.z * s.normal);
  const glm::vec3 colour = glm::clamp(s.colour + f * 0.25f * signed_unit3(hash(key, kColourNoise)),
                                      glm::vec3(0.0f), glm::vec3(1.0f));
  g.sh_dc = (colour - 0.5f) / float(kShC0);
  // Degree 1: a small term that brightens the surface seen head-on (see SH1 basis signs).
  const float spec = 0.06f;
  g.sh_rest[0] = glm::vec3(spec * s.normal.y);
  g.sh_rest[1] = glm::vec3(-spec * s.normal.z);
  g.sh_rest[2] = glm::vec3(spec * s.normal.x);
  const float final_opacity = 0.95f + 0.045f * unit(hash(key, kOpacity));
  g.opacity_logit = logit(final_opacity + f * (0.15f - final_opacity));
  // Flat along the surface: sigma = 0.65 x spacing tangentially, a tenth of that along n.
  // With final opacity 0.95..0.995 this leaves no see-through gaps between neighbours
  // (0.55 left ~10 % transmittance between rows; 0.75+ blurs edges: measured with the
  // reference rasterizer against render_ground_truth). Young Gaussians are blurrier.
  const float grow = 1.0f + 0.5f * f;
  const float su = 0.65f * s.spacing.x * grow, sv = 0.65f * s.spacing.y * grow;
  g.log_scale = glm::vec3(std::log(su), std::log(sv), std::log(0.1f * std::min(su, sv)));
  const glm::mat3 axes(s.tangent, bitangent, s.normal);  // columns: local x, y, z in world
  const glm::quat q = glm::normalize(glm::quat_cast(axes));
  g.rotation = glm::vec4(q.w, q.x, q.y, q.z);
  g.support = static_cast<std::uint32_t>(1 + 3 * std::min(age, K));
  return g;
}

Gaussian SyntheticScene::Impl::carrier_of(std::size_t k) const {
  const Carrier& c = carriers[k];
  Gaussian g;
  g.position = c.position;
  g.log_scale = glm::vec3(std::log(c.size));
  g.opacity_logit = logit(0.1f);
  g.sh_dc = glm::vec3(0.0f);
  g.object = c.object;
  g.support = 1;
  g.carrier = true;
  return g;
}

Expected<SyntheticScene> SyntheticScene::create(const SyntheticSceneConfig& config) {
  const auto bad = [](const std::string& what) { return Error{"SyntheticSceneConfig: " + what}; };
  if (config.variant < 0 || config.variant > 3)
    return bad("variant " + std::to_string(config.variant) + " is outside 0..3");
  if (config.target_gaussians < 100 || config.target_gaussians > 4'000'000)
    return bad("target_gaussians " + std::to_string(config.target_gaussians) + " is outside 100..4000000");
  if (config.epochs < 1 || config.epochs > 10000) return bad("epochs " + std::to_string(config.epochs) + " is outside 1..10000");
  if (config.cameras_per_epoch < 1 || config.cameras_per_epoch > 1000)
    return bad("cameras_per_epoch " + std::to_string(config.cameras_per_epoch) + " is outside 1..1000");
  if (config.converge_epochs < 1 || config.converge_epochs > 1000)
    return bad("converge_epochs " + std::to_string(config.converge_epochs) + " is outside 1..1000");
  if (!(config.prune_fraction >= 0.0f && config.prune_fraction <= 0.5f))
    return bad("prune_fraction " + std::to_string(config.prune_fraction) + " is outside [0, 0.5]");
  if (config.carriers_per_object < 0 || config.carriers_per_object > 1000)
    return bad("carriers_per_object " + std::to_string(config.carriers_per_object) + " is outside 0..1000");
  if (config.image_width < 1 || config.image_height < 1 || config.image_width > 16384 || config.image_height > 16384)
    return bad("image size " + std::to_string(config.image_width) + "x" + std::to_string(config.image_height) +
               " is outside 1..16384");
  if (!(config.focal_px > 0.0 && std::isfinite(config.focal_px)))
    return bad("focal_px " + std::to_string(config.focal_px) + " must be positive");

  auto impl = std::make_unique<Impl>();
  impl->config = config;
  impl->room = scene::build_room(config.variant);
  impl->build_trajectory();
  // Surfaces no camera ever looks at (undersides, hidden faces) would waste the budget:
  // measure the observed share at the target density, resample denser by its inverse and
  // keep only the observed samples, so the fully observed room has ~target_gaussians.
  impl->build_samples(config.target_gaussians);
  impl->observe();
  std::size_t observed = 0;
  for (const Sample& s : impl->samples) observed += s.first_seen != kNever;
  if (observed == 0) return bad("no camera of the trajectory sees any surface");
  if (observed < impl->samples.size()) {
    const double scale = double(impl->samples.size()) / double(observed);
    impl->build_samples(static_cast<std::size_t>(std::llround(double(config.target_gaussians) * scale)));
    impl->observe();
    std::erase_if(impl->samples, [](const Sample& s) { return s.first_seen == kNever; });
  }
  impl->live_id.assign(impl->samples.size(), 0);
  impl->birth.assign(impl->samples.size(), 0);

  for (std::size_t o = 0; o < impl->room.objects.size(); ++o) {
    SyntheticObjectInfo info;
    info.id = impl->room.objects[o].id;
    info.label = impl->room.objects[o].label;
    info.extent_min = glm::vec3(std::numeric_limits<float>::max());
    info.extent_max = glm::vec3(std::numeric_limits<float>::lowest());
    for (const auto& prim : impl->room.primitives)
      if (prim.object == info.id) {
        glm::vec3 lo, hi;
        scene::primitive_bounds(prim, lo, hi);
        info.extent_min = glm::min(info.extent_min, lo);
        info.extent_max = glm::max(info.extent_max, hi);
      }
    for (int c = 0; c < config.carriers_per_object; ++c) {
      const std::uint64_t key = hash(config.seed, kCarrier, o, static_cast<std::uint64_t>(c));
      const glm::vec3 r = 0.5f * (signed_unit3(key) + 1.0f);
      const glm::vec3 size = info.extent_max - info.extent_min;
      impl->carriers.push_back({info.extent_min + r * size, 0.25f * std::max(size.x, std::max(size.y, size.z)), info.id});
    }
    impl->objects.push_back(std::move(info));
  }
  return SyntheticScene(std::move(impl));
}

SyntheticScene::SyntheticScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SyntheticScene::SyntheticScene(SyntheticScene&&) noexcept = default;
SyntheticScene& SyntheticScene::operator=(SyntheticScene&&) noexcept = default;
SyntheticScene::~SyntheticScene() = default;

const SyntheticSceneConfig& SyntheticScene::config() const { return impl_->config; }
int SyntheticScene::produced() const { return impl_->produced; }
const std::vector<Camera>& SyntheticScene::trajectory() const { return impl_->trajectory; }
const std::vector<SyntheticObjectInfo>& SyntheticScene::objects() const { return impl_->objects; }
glm::vec3 SyntheticScene::room_min() const { return impl_->room.min; }
glm::vec3 SyntheticScene::room_max() const { return impl_->room.max; }
TriangleMesh SyntheticScene::surface_mesh() const { return scene::tessellate(impl_->room); }

std::span<const Camera> SyntheticScene::cameras_of_epoch(int e) const {
  if (e < 0 || e >= epoch_count()) return {};
  const auto k = static_cast<std::size_t>(impl_->config.cameras_per_epoch);
  return std::span<const Camera>(impl_->trajectory).subspan(static_cast<std::size_t>(e) * k, k);
}

float SyntheticScene::distance_to_surface(const glm::vec3& p) const {
  float d = std::numeric_limits<float>::max();
  for (const auto& prim : impl_->room.primitives) d = std::min(d, scene::surface_distance(prim, p));
  return d;
}

Status SyntheticScene::produce(SceneStore& store) {
  Impl& m = *impl_;
  if (finished())
    return Error{"SyntheticScene::produce: all " + std::to_string(m.config.epochs) + " epochs were produced"};
  if (store.in_epoch()) return Error{"SyntheticScene::produce: the store has an open epoch"};
  const int e = m.produced;
  if (auto s = store.begin_next_epoch(); !s) return s;
  // Any failure below means the store was also fed by someone else (ids clash): commit what
  // was applied so the store stays consistent, and report the first error.
  Status first_error = Ok{};
  const auto check = [&](Status s) {
    if (!s && first_error) first_error = std::move(s);
  };
  if (e == 0) check(store.set_sh_degree(1));
  if (e == 0 && m.config.surface_chunk) check(store.set_surface_chunk({0, Epoch{0}, scene::tessellate(m.room)}));
  for (std::size_t o = 0; o < m.room.objects.size(); ++o) {
    if (m.object_first_seen[o] > e) continue;
    // Observation quality: the share of the object's surface samples observed so far.
    std::size_t seen = 0;
    for (int k = 0; k <= e; ++k) seen += m.object_seen_per_epoch[o][static_cast<std::size_t>(k)];
    const float quality = float(seen) / float(std::max<std::size_t>(1, m.object_samples[o]));
    check(store.set_object(m.room.objects[o].id, m.room.objects[o].label, std::min(1.0f, quality)));
  }
  const auto K = m.config.converge_epochs;
  for (std::size_t i = 0; i < m.samples.size(); ++i) {
    if (m.live_id[i] != 0) {
      const int age = e - m.birth[i];
      if (age > K && unit(hash(m.config.seed, kPrune, i, static_cast<std::uint64_t>(e))) < m.config.prune_fraction) {
        check(store.remove(GaussianId{m.live_id[i]}));
        m.live_id[i] = m.next_id++;
        m.birth[i] = static_cast<std::int16_t>(e);
        check(store.insert(m.gaussian_of(i, e)));
      } else if (age <= K) {
        check(store.modify(m.gaussian_of(i, e)));
      }
    } else if (m.samples[i].first_seen <= e) {
      m.live_id[i] = m.next_id++;
      m.birth[i] = static_cast<std::int16_t>(e);
      check(store.insert(m.gaussian_of(i, e)));
    }
  }
  for (std::size_t k = 0; k < m.carriers.size(); ++k) {
    const auto o = static_cast<std::size_t>(to_underlying(m.carriers[k].object) - 1);
    if (m.object_first_seen[o] != e) continue;
    Gaussian g = m.carrier_of(k);
    g.id = GaussianId{m.next_id++};
    check(store.insert(g));
  }
  if (auto s = store.commit_epoch(); !s) return s;
  ++m.produced;
  return first_error;
}

GroundTruthImage SyntheticScene::render_ground_truth(const Camera& camera) const {
  GroundTruthImage out;
  const std::uint32_t w = camera.width, h = camera.height;
  out.colour.width = w;
  out.colour.height = h;
  out.colour.pixels.assign(std::size_t(w) * h * 4, 0);
  out.depth.assign(std::size_t(w) * h, 0.0f);
  out.object.assign(std::size_t(w) * h, kNoObject);
  const glm::dmat3 rot(camera.world_to_camera);
  const glm::dvec3 trans(camera.world_to_camera[3]);
  const glm::dmat3 cam_to_world = glm::transpose(rot);
  const glm::vec3 eye(-cam_to_world * trans);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      // Ray through the pixel centre with camera-z component 1, so t is the z depth.
      const glm::dvec3 d_cam((x + 0.5 - camera.cx) / camera.fx, (y + 0.5 - camera.cy) / camera.fy, 1.0);
      const glm::vec3 dir(cam_to_world * d_cam);
      scene::Hit hit;
      if (!scene::intersect(impl_->room, eye, dir, 1e-4f, float(camera.far_plane), hit)) continue;
      const glm::vec3 p = eye + hit.t * dir;
      const scene::Primitive& prim = impl_->room.primitives[static_cast<std::size_t>(hit.primitive)];
      const glm::vec3 c = scene::surface_colour(prim, p, hit.normal);
      const std::size_t px = std::size_t(y) * w + x;
      out.depth[px] = hit.t;
      out.object[px] = prim.object;
      for (int k = 0; k < 3; ++k) out.colour.pixels[px * 4 + k] = static_cast<std::uint8_t>(c[k] * 255.0f + 0.5f);
      out.colour.pixels[px * 4 + 3] = 255;
    }
  return out;
}

}  // namespace gauss
