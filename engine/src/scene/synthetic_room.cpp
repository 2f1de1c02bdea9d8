#include "synthetic_room.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <glm/geometric.hpp>

#include "prng.h"

namespace gauss::scene {
namespace {

// Rotation about +y by yaw (local -> world) and its inverse.
glm::vec3 rot_y(const glm::vec3& v, float yaw) {
  const float c = std::cos(yaw), s = std::sin(yaw);
  return {c * v.x + s * v.z, v.y, -s * v.x + c * v.z};
}

float smooth(float t) { return t * t * (3.0f - 2.0f * t); }

// Fixed value noise in [0, 1]: smooth interpolation of hashed lattice values.
float value_noise(const glm::vec3& p) {
  const glm::vec3 f = glm::floor(p);
  const glm::vec3 t = p - f;
  const auto lattice = [&](int dx, int dy, int dz) {
    const auto ix = static_cast<std::uint64_t>(static_cast<std::int64_t>(f.x) + dx);
    const auto iy = static_cast<std::uint64_t>(static_cast<std::int64_t>(f.y) + dy);
    const auto iz = static_cast<std::uint64_t>(static_cast<std::int64_t>(f.z) + dz);
    return unit(hash(ix, iy, iz, 0x5EED));
  };
  const float sx = smooth(t.x), sy = smooth(t.y), sz = smooth(t.z);
  float v[2];
  for (int z = 0; z < 2; ++z) {
    const float a = lattice(0, 0, z) + (lattice(1, 0, z) - lattice(0, 0, z)) * sx;
    const float b = lattice(0, 1, z) + (lattice(1, 1, z) - lattice(0, 1, z)) * sx;
    v[z] = a + (b - a) * sy;
  }
  return v[0] + (v[1] - v[0]) * sz;
}

float fract(float x) { return x - std::floor(x); }

glm::vec3 albedo_at(const Primitive& prim, const glm::vec3& p, const glm::vec3& n) {
  glm::vec3 base = prim.albedo;
  Pattern pattern = prim.pattern;
  if (prim.inward) {  // room shell: floor / walls / ceiling by the facing direction
    if (n.y > 0.5f) {
      base = prim.floor_albedo;
      pattern = prim.floor_pattern;
    } else if (n.y < -0.5f) {
      base = prim.ceiling_albedo;
      pattern = Pattern::Plain;
    }
  }
  const glm::vec3 local = rot_y(p - prim.center, -prim.yaw);
  switch (pattern) {
    case Pattern::Planks: {
      // Boards 0.2 m wide along x, 1.5 m long with staggered joints and dark seams.
      const float row = std::floor(p.z / 0.2f);
      const auto row_key = static_cast<std::uint64_t>(static_cast<std::int64_t>(row));
      const float x = p.x + 1.5f * unit(hash(row_key, 17));
      const auto board = static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(x / 1.5f)));
      const float shade = 0.82f + 0.3f * unit(hash(row_key, board, 23));
      const float grain = 1.0f + 0.05f * std::sin(x * 37.0f + 6.0f * unit(hash(row_key, board, 29)));
      const bool seam = fract(p.z / 0.2f) < 0.05f || fract(x / 1.5f) < 0.006f;
      return base * shade * grain * (seam ? 0.55f : 1.0f);
    }
    case Pattern::Tiles: {
      const float tx = fract(p.x / 0.6f), tz = fract(p.z / 0.6f);
      if (tx < 0.03f || tz < 0.03f) return glm::vec3(0.8f);  // grout
      const bool odd = (static_cast<std::int64_t>(std::floor(p.x / 0.6f)) +
                        static_cast<std::int64_t>(std::floor(p.z / 0.6f))) & 1;
      return base * (odd ? 0.8f : 1.0f) * (0.95f + 0.1f * value_noise(p * 9.0f));
    }
    case Pattern::Keys: {
      if (n.y < 0.5f) return base;
      const float kx = fract(local.x / 0.019f), kz = fract(local.z / 0.019f);
      const bool gap = kx < 0.15f || kz < 0.15f;
      return gap ? base * 0.5f : glm::vec3(0.72f);
    }
    case Pattern::Leaves:
      return base * (0.55f + 0.9f * value_noise(p * 24.0f));
    case Pattern::Screen: {
      const glm::vec3 ln = rot_y(n, -prim.yaw);
      if (std::abs(ln.z) < 0.5f) return base;
      const float h = std::clamp(local.y / (2.0f * prim.half.y) + 0.5f, 0.0f, 1.0f);
      return glm::vec3(0.08f, 0.12f + 0.15f * h, 0.3f + 0.3f * h);
    }
    case Pattern::Fabric:
      return base * (0.9f + 0.2f * value_noise(p * 60.0f));
    case Pattern::Plain:
      break;
  }
  return base * (0.96f + 0.08f * value_noise(p * 3.0f));
}

float box_sd(const glm::vec3& q_local, const glm::vec3& half) {
  const glm::vec3 q = glm::abs(q_local) - half;
  const float outside = glm::length(glm::max(q, glm::vec3(0.0f)));
  const float inside = std::min(std::max(q.x, std::max(q.y, q.z)), 0.0f);
  return outside + inside;
}

}  // namespace

float surface_distance(const Primitive& prim, const glm::vec3& p) {
  switch (prim.shape) {
    case Shape::Box:
      return std::abs(box_sd(rot_y(p - prim.center, -prim.yaw), prim.half));
    case Shape::Cylinder: {
      const glm::vec3 q = p - prim.center;
      const float dx = std::sqrt(q.x * q.x + q.z * q.z) - prim.half.x;
      const float dy = std::abs(q.y) - prim.half.y;
      const float sd = std::min(std::max(dx, dy), 0.0f) + std::sqrt(std::max(dx, 0.0f) * std::max(dx, 0.0f) +
                                                                   std::max(dy, 0.0f) * std::max(dy, 0.0f));
      return std::abs(sd);
    }
    case Shape::Sphere:
      return std::abs(glm::length(p - prim.center) - prim.half.x);
  }
  return 0.0f;
}

glm::vec3 surface_colour(const Primitive& prim, const glm::vec3& p, const glm::vec3& n) {
  // Baked, view-independent light: ambient plus one soft key light from above.
  static const glm::vec3 kLight = glm::normalize(glm::vec3(0.35f, 1.0f, 0.25f));
  const float light = 0.62f + 0.38f * std::max(0.0f, glm::dot(n, kLight));
  return glm::clamp(albedo_at(prim, p, n) * light, glm::vec3(0.0f), glm::vec3(1.0f));
}

namespace {

// Box in its local frame: slab test; returns the entry (outward box) or exit (inward).
bool hit_box(const Primitive& prim, const glm::vec3& o_world, const glm::vec3& d_world, float t_min, float t_max,
             float& t_out, glm::vec3& n_out) {
  const glm::vec3 o = rot_y(o_world - prim.center, -prim.yaw);
  const glm::vec3 d = rot_y(d_world, -prim.yaw);
  float t0 = -std::numeric_limits<float>::infinity(), t1 = std::numeric_limits<float>::infinity();
  int axis0 = -1, axis1 = -1;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12f) {
      if (std::abs(o[a]) > prim.half[a]) return false;
      continue;
    }
    float ta = (-prim.half[a] - o[a]) / d[a], tb = (prim.half[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) { t0 = ta; axis0 = a; }
    if (tb < t1) { t1 = tb; axis1 = a; }
  }
  if (t0 > t1) return false;
  float t;
  int axis;
  if (prim.inward) {
    t = t1;
    axis = axis1;
  } else {
    t = t0;
    axis = axis0;
  }
  if (axis < 0 || !(t > t_min) || t > t_max) return false;
  glm::vec3 n(0.0f);
  n[axis] = d[axis] > 0.0f ? -1.0f : 1.0f;  // faces the incoming ray
  t_out = t;
  n_out = rot_y(n, prim.yaw);
  return true;
}

bool hit_cylinder(const Primitive& prim, const glm::vec3& o_world, const glm::vec3& d, float t_min, float t_max,
                  float& t_out, glm::vec3& n_out) {
  const glm::vec3 o = o_world - prim.center;
  const float r = prim.half.x, h = prim.half.y;
  bool found = false;
  float best = t_max;
  const float a = d.x * d.x + d.z * d.z;
  if (a > 1e-12f) {
    const float b = o.x * d.x + o.z * d.z;
    const float c = o.x * o.x + o.z * o.z - r * r;
    const float disc = b * b - a * c;
    if (disc >= 0.0f) {
      const float sq = std::sqrt(disc);
      for (float t : {(-b - sq) / a, (-b + sq) / a}) {
        if (t > t_min && t <= best && std::abs(o.y + t * d.y) <= h) {
          best = t;
          found = true;
          n_out = glm::vec3(o.x + t * d.x, 0.0f, o.z + t * d.z) / r;
          break;
        }
      }
    }
  }
  if (std::abs(d.y) > 1e-12f) {
    for (float cap : {-h, h}) {
      const float t = (cap - o.y) / d.y;
      const float x = o.x + t * d.x, z = o.z + t * d.z;
      if (t > t_min && t <= best && x * x + z * z <= r * r) {
        best = t;
        found = true;
        n_out = glm::vec3(0.0f, cap > 0.0f ? 1.0f : -1.0f, 0.0f);
      }
    }
  }
  if (!found) return false;
  if (glm::dot(n_out, d) > 0.0f) n_out = -n_out;
  t_out = best;
  return true;
}

bool hit_sphere(const Primitive& prim, const glm::vec3& o_world, const glm::vec3& d, float t_min, float t_max,
                float& t_out, glm::vec3& n_out) {
  const glm::vec3 o = o_world - prim.center;
  const float a = glm::dot(d, d), b = glm::dot(o, d), c = glm::dot(o, o) - prim.half.x * prim.half.x;
  const float disc = b * b - a * c;
  if (disc < 0.0f) return false;
  const float sq = std::sqrt(disc);
  for (float t : {(-b - sq) / a, (-b + sq) / a}) {
    if (t > t_min && t <= t_max) {
      n_out = (o + t * d) / prim.half.x;
      if (glm::dot(n_out, d) > 0.0f) n_out = -n_out;
      t_out = t;
      return true;
    }
  }
  return false;
}

}  // namespace

void primitive_bounds(const Primitive& prim, glm::vec3& out_min, glm::vec3& out_max) {
  glm::vec3 ext = prim.half;
  if (prim.shape == Shape::Box) {
    const float c = std::abs(std::cos(prim.yaw)), s = std::abs(std::sin(prim.yaw));
    ext = glm::vec3(c * prim.half.x + s * prim.half.z, prim.half.y, s * prim.half.x + c * prim.half.z);
  }
  out_min = prim.center - ext;
  out_max = prim.center + ext;
}

namespace {

// Slab test against an AABB: can the segment (t_min, t_max] touch it?
bool hits_aabb(const glm::vec3& lo, const glm::vec3& hi, const glm::vec3& o, const glm::vec3& inv_d, float t_min,
               float t_max) {
  for (int a = 0; a < 3; ++a) {
    float t0 = (lo[a] - o[a]) * inv_d[a], t1 = (hi[a] - o[a]) * inv_d[a];
    if (t0 > t1) std::swap(t0, t1);
    t_min = std::max(t_min, t0);
    t_max = std::min(t_max, t1);
    if (t_min > t_max) return false;
  }
  return true;
}

bool hit_primitive(const Primitive& prim, const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max,
                   float& t, glm::vec3& n) {
  switch (prim.shape) {
    case Shape::Box: return hit_box(prim, origin, dir, t_min, t_max, t, n);
    case Shape::Cylinder: return hit_cylinder(prim, origin, dir, t_min, t_max, t, n);
    case Shape::Sphere: return hit_sphere(prim, origin, dir, t_min, t_max, t, n);
  }
  return false;
}

}  // namespace

bool intersect(const Room& room, const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max, Hit& out) {
  bool found = false;
  // 1/0 = inf makes the slab test work for axis-parallel rays (IEEE semantics).
  const glm::vec3 inv_d(1.0f / dir.x, 1.0f / dir.y, 1.0f / dir.z);
  for (const PrimitiveGroup& g : room.groups) {
    if (!room.primitives[static_cast<std::size_t>(g.first)].inward &&
        !hits_aabb(g.min, g.max, origin, inv_d, t_min, t_max))
      continue;
    for (int i = g.first; i < g.first + g.count; ++i) {
      float t = 0.0f;
      glm::vec3 n(0.0f);
      if (hit_primitive(room.primitives[static_cast<std::size_t>(i)], origin, dir, t_min, t_max, t, n)) {
        t_max = t;
        out = Hit{t, n, i};
        found = true;
      }
    }
  }
  return found;
}

std::vector<Patch> surface_patches(const Room& room) {
  std::vector<Patch> patches;
  for (std::size_t pi = 0; pi < room.primitives.size(); ++pi) {
    const Primitive& prim = room.primitives[pi];
    const int idx = static_cast<int>(pi);
    const float flip = prim.inward ? -1.0f : 1.0f;
    switch (prim.shape) {
      case Shape::Box:
        for (int axis = 0; axis < 3; ++axis)
          for (float s : {-1.0f, 1.0f}) {
            if (axis == 1 && s < 0.0f && prim.rests_on_floor) continue;
            glm::vec3 e(0.0f);
            e[axis] = s;
            const int ua = (axis + 1) % 3, va = (axis + 2) % 3;
            glm::vec3 u(0.0f), v(0.0f);
            u[ua] = 2.0f * prim.half[ua];
            v[va] = 2.0f * prim.half[va];
            Patch p;
            p.kind = Patch::Kind::Rect;
            p.primitive = idx;
            const glm::vec3 face_center = e * prim.half[axis];
            p.origin = prim.center + rot_y(face_center - 0.5f * u - 0.5f * v, prim.yaw);
            p.axis_u = rot_y(u, prim.yaw);
            p.axis_v = rot_y(v, prim.yaw);
            p.normal = rot_y(e, prim.yaw) * flip;
            p.area = u[ua] * v[va];
            patches.push_back(p);
          }
        break;
      case Shape::Cylinder: {
        Patch side;
        side.kind = Patch::Kind::CylinderSide;
        side.primitive = idx;
        side.origin = prim.center;
        side.radius = prim.half.x;
        side.normal = glm::vec3(0.0f, prim.half.y, 0.0f);
        side.inward = prim.inward;
        side.area = 2.0f * kPi * prim.half.x * 2.0f * prim.half.y;
        patches.push_back(side);
        for (float s : {-1.0f, 1.0f}) {
          if (s < 0.0f && prim.rests_on_floor) continue;
          Patch cap;
          cap.kind = Patch::Kind::Disk;
          cap.primitive = idx;
          cap.origin = prim.center + glm::vec3(0.0f, s * prim.half.y, 0.0f);
          cap.radius = prim.half.x;
          cap.axis_u = glm::vec3(1.0f, 0.0f, 0.0f);
          cap.axis_v = glm::vec3(0.0f, 0.0f, 1.0f);
          cap.normal = glm::vec3(0.0f, s * flip, 0.0f);
          cap.area = kPi * prim.half.x * prim.half.x;
          patches.push_back(cap);
        }
        break;
      }
      case Shape::Sphere: {
        Patch sp;
        sp.kind = Patch::Kind::Sphere;
        sp.primitive = idx;
        sp.origin = prim.center;
        sp.radius = prim.half.x;
        sp.inward = prim.inward;
        sp.area = 4.0f * kPi * prim.half.x * prim.half.x;
        patches.push_back(sp);
        break;
      }
    }
  }
  return patches;
}

SurfacePoint sample_patch(const Patch& patch, glm::vec2 uv) {
  SurfacePoint sp{};
  switch (patch.kind) {
    case Patch::Kind::Rect:
      sp.position = patch.origin + uv.x * patch.axis_u + uv.y * patch.axis_v;
      sp.normal = patch.normal;
      sp.tangent = glm::normalize(patch.axis_u);
      break;
    case Patch::Kind::Disk: {
      const float r = patch.radius * std::sqrt(uv.x), phi = 2.0f * kPi * uv.y;
      sp.position = patch.origin + r * (std::cos(phi) * patch.axis_u + std::sin(phi) * patch.axis_v);
      sp.normal = patch.normal;
      sp.tangent = glm::vec3(-std::sin(phi), 0.0f, std::cos(phi));
      break;
    }
    case Patch::Kind::CylinderSide: {
      const float phi = 2.0f * kPi * uv.x;
      const glm::vec3 radial(std::cos(phi), 0.0f, std::sin(phi));
      sp.position = patch.origin + patch.radius * radial + (2.0f * uv.y - 1.0f) * patch.normal;
      sp.normal = patch.inward ? -radial : radial;
      sp.tangent = glm::vec3(-std::sin(phi), 0.0f, std::cos(phi));
      break;
    }
    case Patch::Kind::Sphere: {
      const float z = 1.0f - 2.0f * uv.x, phi = 2.0f * kPi * uv.y;
      const float rr = std::sqrt(std::max(0.0f, 1.0f - z * z));
      const glm::vec3 dir(rr * std::cos(phi), z, rr * std::sin(phi));
      sp.position = patch.origin + patch.radius * dir;
      sp.normal = patch.inward ? -dir : dir;
      sp.tangent = rr > 1e-4f ? glm::vec3(-std::sin(phi), 0.0f, std::cos(phi)) : glm::vec3(1.0f, 0.0f, 0.0f);
      break;
    }
  }
  return sp;
}

namespace {

struct MeshBuilder {
  TriangleMesh mesh;
  const Primitive* prim{nullptr};

  std::uint32_t vertex(const glm::vec3& p, const glm::vec3& n) {
    const glm::vec3 c = surface_colour(*prim, p, n) * 255.0f + 0.5f;
    mesh.positions.push_back(p);
    mesh.colors.emplace_back(static_cast<std::uint8_t>(c.x), static_cast<std::uint8_t>(c.y),
                             static_cast<std::uint8_t>(c.z));
    return static_cast<std::uint32_t>(mesh.positions.size() - 1);
  }
  // Counter-clockwise seen from the side `n` points to.
  void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c, const glm::vec3& n) {
    const glm::vec3& pa = mesh.positions[a];
    if (glm::dot(glm::cross(mesh.positions[b] - pa, mesh.positions[c] - pa), n) < 0.0f) std::swap(b, c);
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
  }
  // A grid over (u, v) in [0,1]^2 of sample_patch, cells about `cell` metres.
  void grid(const Patch& patch, int nu, int nv) {
    const std::uint32_t base = static_cast<std::uint32_t>(mesh.positions.size());
    for (int j = 0; j <= nv; ++j)
      for (int i = 0; i <= nu; ++i) {
        const SurfacePoint sp = sample_patch(patch, {float(i) / float(nu), float(j) / float(nv)});
        vertex(sp.position, sp.normal);
      }
    const auto at = [&](int i, int j) { return base + static_cast<std::uint32_t>(j * (nu + 1) + i); };
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        const SurfacePoint mid = sample_patch(patch, {(float(i) + 0.5f) / float(nu), (float(j) + 0.5f) / float(nv)});
        triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1), mid.normal);
        triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1), mid.normal);
      }
  }
};

int cells(float length, float cell) { return std::max(1, static_cast<int>(std::ceil(length / cell))); }

}  // namespace

TriangleMesh tessellate(const Room& room) {
  MeshBuilder b;
  for (const Patch& patch : surface_patches(room)) {
    b.prim = &room.primitives[static_cast<std::size_t>(patch.primitive)];
    switch (patch.kind) {
      case Patch::Kind::Rect:
        b.grid(patch, cells(glm::length(patch.axis_u), 0.25f), cells(glm::length(patch.axis_v), 0.25f));
        break;
      case Patch::Kind::Disk: b.grid(patch, 2, 24); break;
      case Patch::Kind::CylinderSide: b.grid(patch, 24, cells(2.0f * patch.normal.y, 0.25f)); break;
      case Patch::Kind::Sphere: b.grid(patch, 12, 24); break;
    }
  }
  return std::move(b.mesh);
}

}  // namespace gauss::scene
