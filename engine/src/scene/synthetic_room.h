#pragma once
// The analytic room behind SyntheticScene: primitives (boxes turned about y, vertical
// cylinders, spheres), their exact ray intersection and surface distance, their
// procedural colour (albedo pattern x baked, view-independent lighting), and surface
// patches used to place Gaussians.
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "gauss/engine/ids.h"
#include "gauss/engine/mesh.h"

namespace gauss::scene {

inline constexpr float kPi = std::numbers::pi_v<float>;

enum class Shape : std::uint8_t { Box, Cylinder, Sphere };

// Albedo patterns; the room shell picks per face (floor/wall/ceiling) in its own way.
enum class Pattern : std::uint8_t { Plain, Planks, Tiles, Keys, Leaves, Screen, Fabric };

struct Primitive {
  Shape shape{Shape::Box};
  glm::vec3 center{0.0f};  // box / sphere centre; cylinder axis midpoint
  glm::vec3 half{0.5f};    // box half extents (local axes); cylinder (r, half height, r); sphere (r, r, r)
  float yaw{0.0f};         // radians about +y (boxes)
  bool inward{false};      // room shell: seen from inside, normals point inwards
  bool rests_on_floor{false};  // bottom face/cap touches the floor: never visible, not sampled
  glm::vec3 albedo{0.7f};
  Pattern pattern{Pattern::Plain};
  ObjectId object{kNoObject};
  // Room shell only: floor, wall and ceiling albedo/patterns.
  glm::vec3 floor_albedo{0.6f}, ceiling_albedo{0.9f};
  Pattern floor_pattern{Pattern::Planks};
};

struct Hit {
  float t{0.0f};
  glm::vec3 normal{0.0f};  // facing the incoming ray's side of the surface
  int primitive{-1};
};

struct ObjectSpec {
  ObjectId id{kNoObject};
  std::string label;
};

// A run of primitives with one world AABB, so a ray skips a whole object at once.
struct PrimitiveGroup {
  int first{0};
  int count{0};
  glm::vec3 min{0.0f}, max{0.0f};
};

struct Room {
  glm::vec3 min{0.0f}, max{0.0f};  // interior
  std::vector<Primitive> primitives;  // [0] is the room shell
  std::vector<ObjectSpec> objects;
  std::vector<PrimitiveGroup> groups;  // consecutive primitives of one object (shell alone)
};

// World-space bounds of one primitive.
void primitive_bounds(const Primitive& prim, glm::vec3& out_min, glm::vec3& out_max);

// Builds variant 0..3 (caller validated the range).
Room build_room(int variant);

// Nearest intersection with t in (t_min, t_max] of origin + t * dir (dir need not be unit).
bool intersect(const Room& room, const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max, Hit& out);
// Unsigned distance from p to the primitive's surface.
float surface_distance(const Primitive& prim, const glm::vec3& p);
// Shaded colour in [0, 1] of the surface point p with outward-facing normal n.
glm::vec3 surface_colour(const Primitive& prim, const glm::vec3& p, const glm::vec3& n);

// A flat or curved piece of a primitive's surface with a uniform-area parametrisation
// (u, v) in [0, 1)^2 -> point, normal, tangent.
struct Patch {
  enum class Kind : std::uint8_t { Rect, Disk, CylinderSide, Sphere } kind{Kind::Rect};
  int primitive{0};
  glm::vec3 origin{0.0f};  // Rect: corner; Disk/CylinderSide/Sphere: centre
  glm::vec3 axis_u{0.0f};  // Rect: full edge vectors; Disk: radius vectors; Cylinder: radial x/z
  glm::vec3 axis_v{0.0f};
  glm::vec3 normal{0.0f};  // Rect/Disk normal; Cylinder: axis * half height
  float radius{0.0f};
  bool inward{false};
  float area{0.0f};
};

struct SurfacePoint {
  glm::vec3 position;
  glm::vec3 normal;
  glm::vec3 tangent;
};

std::vector<Patch> surface_patches(const Room& room);
SurfacePoint sample_patch(const Patch& patch, glm::vec2 uv);

// Tessellates every primitive (visible faces only) with shaded vertex colours.
TriangleMesh tessellate(const Room& room);

}  // namespace gauss::scene
