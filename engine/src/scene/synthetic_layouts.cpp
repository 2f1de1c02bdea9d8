// The four synthetic room variants: furniture built from boxes, cylinders and spheres,
// in plausible sizes (metres) and colours. Every variant has at least two chairs, a table,
// a plant, a keyboard, a robot arm and a shelf; the variants differ in room size, floor,
// colours, layout and extra objects (monitor, lamp, sofa, cabinet, rug).
#include <cmath>
#include <numbers>
#include <string>

#include <glm/common.hpp>

#include "prng.h"
#include "synthetic_room.h"

namespace gauss::scene {
namespace {

// A furniture item's own frame: origin on the floor (or a support), turned by yaw about y.
struct Frame {
  glm::vec3 origin{0.0f};
  float yaw{0.0f};
  glm::vec3 at(const glm::vec3& local) const {
    const float c = std::cos(yaw), s = std::sin(yaw);
    return origin + glm::vec3(c * local.x + s * local.z, local.y, -s * local.x + c * local.z);
  }
};

class Builder {
 public:
  explicit Builder(Room& room) : room_(room) {}

  ObjectId object(const std::string& label) {
    const ObjectId id{static_cast<std::int32_t>(room_.objects.size()) + 1};
    room_.objects.push_back({id, label});
    return id;
  }
  // Box of full size `size` whose centre is at local `center`.
  void box(const Frame& f, ObjectId obj, glm::vec3 center, glm::vec3 size, glm::vec3 albedo,
           Pattern pattern = Pattern::Plain) {
    Primitive p;
    p.shape = Shape::Box;
    p.center = f.at(center);
    p.half = size * 0.5f;
    p.yaw = f.yaw;
    p.albedo = albedo;
    p.pattern = pattern;
    p.object = obj;
    p.rests_on_floor = p.center.y - p.half.y < 1e-4f;
    room_.primitives.push_back(p);
  }
  // Vertical cylinder standing on local `base` (bottom centre).
  void cylinder(const Frame& f, ObjectId obj, glm::vec3 base, float radius, float height, glm::vec3 albedo,
                Pattern pattern = Pattern::Plain) {
    Primitive p;
    p.shape = Shape::Cylinder;
    p.center = f.at(base + glm::vec3(0.0f, 0.5f * height, 0.0f));
    p.half = glm::vec3(radius, 0.5f * height, radius);
    p.albedo = albedo;
    p.pattern = pattern;
    p.object = obj;
    p.rests_on_floor = p.center.y - p.half.y < 1e-4f;
    room_.primitives.push_back(p);
  }
  void sphere(const Frame& f, ObjectId obj, glm::vec3 center, float radius, glm::vec3 albedo,
              Pattern pattern = Pattern::Plain) {
    Primitive p;
    p.shape = Shape::Sphere;
    p.center = f.at(center);
    p.half = glm::vec3(radius);
    p.albedo = albedo;
    p.pattern = pattern;
    p.object = obj;
    room_.primitives.push_back(p);
  }

  void shell(glm::vec3 size, glm::vec3 wall, glm::vec3 floor, Pattern floor_pattern) {
    room_.min = glm::vec3(-0.5f * size.x, 0.0f, -0.5f * size.z);
    room_.max = glm::vec3(0.5f * size.x, size.y, 0.5f * size.z);
    Primitive p;
    p.shape = Shape::Box;
    p.center = 0.5f * (room_.min + room_.max);
    p.half = 0.5f * size;
    p.inward = true;
    p.albedo = wall;
    p.floor_albedo = floor;
    p.floor_pattern = floor_pattern;
    p.ceiling_albedo = glm::vec3(0.93f, 0.93f, 0.9f);
    room_.primitives.push_back(p);
  }

  // Four legs and a top; returns the height of the top surface.
  float table(Frame f, glm::vec2 size, float height, glm::vec3 wood) {
    const ObjectId id = object("table");
    const float top = 0.04f, leg = 0.06f;
    box(f, id, {0.0f, height - 0.5f * top, 0.0f}, {size.x, top, size.y}, wood);
    for (float sx : {-1.0f, 1.0f})
      for (float sz : {-1.0f, 1.0f})
        box(f, id, {sx * (0.5f * size.x - 0.08f), 0.5f * (height - top), sz * (0.5f * size.y - 0.08f)},
            {leg, height - top, leg}, wood * 0.85f);
    return height;
  }
  // Seat facing local +z (backrest on the -z side).
  void chair(Frame f, glm::vec3 colour, glm::vec3 frame_colour) {
    const ObjectId id = object("chair");
    const float seat_h = 0.45f, w = 0.46f;
    box(f, id, {0.0f, seat_h, 0.0f}, {w, 0.06f, w}, colour, Pattern::Fabric);
    box(f, id, {0.0f, seat_h + 0.3f, -0.5f * w + 0.025f}, {w, 0.48f, 0.05f}, colour, Pattern::Fabric);
    for (float sx : {-1.0f, 1.0f})
      for (float sz : {-1.0f, 1.0f})
        box(f, id, {sx * (0.5f * w - 0.03f), 0.5f * (seat_h - 0.03f), sz * (0.5f * w - 0.03f)},
            {0.035f, seat_h - 0.03f, 0.035f}, frame_colour);
  }
  void plant(Frame f, float scale, glm::vec3 pot, glm::vec3 leaves) {
    const ObjectId id = object("plant");
    const float pot_h = 0.32f * scale, pot_r = 0.16f * scale;
    cylinder(f, id, {0.0f, 0.0f, 0.0f}, pot_r, pot_h, pot);
    sphere(f, id, {0.0f, pot_h + 0.26f * scale, 0.0f}, 0.27f * scale, leaves, Pattern::Leaves);
    sphere(f, id, {0.12f * scale, pot_h + 0.45f * scale, 0.06f * scale}, 0.19f * scale, leaves * 1.1f,
           Pattern::Leaves);
    sphere(f, id, {-0.1f * scale, pot_h + 0.42f * scale, -0.09f * scale}, 0.17f * scale, leaves * 0.9f,
           Pattern::Leaves);
  }
  void keyboard(Frame f) {
    const ObjectId id = object("keyboard");
    box(f, id, {0.0f, 0.0125f, 0.0f}, {0.45f, 0.025f, 0.15f}, glm::vec3(0.16f), Pattern::Keys);
  }
  // Screen facing local +z.
  void monitor(Frame f) {
    const ObjectId id = object("monitor");
    box(f, id, {0.0f, 0.008f, 0.0f}, {0.26f, 0.016f, 0.2f}, glm::vec3(0.12f));
    box(f, id, {0.0f, 0.14f, -0.04f}, {0.05f, 0.25f, 0.04f}, glm::vec3(0.12f));
    box(f, id, {0.0f, 0.36f, 0.0f}, {0.62f, 0.37f, 0.03f}, glm::vec3(0.1f), Pattern::Screen);
  }
  // Open front on local +z, back against a wall on -z.
  void shelf(Frame f, glm::vec3 wood, std::uint64_t seed) {
    const ObjectId id = object("shelf");
    const float w = 1.2f, h = 1.8f, d = 0.34f;
    for (float sx : {-1.0f, 1.0f}) box(f, id, {sx * (0.5f * w - 0.015f), 0.5f * h, 0.0f}, {0.03f, h, d}, wood);
    box(f, id, {0.0f, 0.5f * h, -0.5f * d + 0.006f}, {w - 0.06f, h, 0.012f}, wood * 0.8f);
    const float boards[] = {0.04f, 0.48f, 0.92f, 1.36f, 1.785f};
    for (float y : boards) box(f, id, {0.0f, y, 0.0f}, {w - 0.06f, 0.03f, d - 0.012f}, wood);
    // Books on the lower three boards: widths, heights and colours from the seed.
    for (int level = 0; level < 3; ++level) {
      float x = -0.5f * w + 0.05f;
      for (int k = 0; x < 0.5f * w - 0.12f; ++k) {
        const std::uint64_t key = hash(seed, static_cast<std::uint64_t>(level), static_cast<std::uint64_t>(k));
        const float bw = 0.03f + 0.04f * unit(hash(key, 1));
        const float bh = 0.2f + 0.14f * unit(hash(key, 2));
        if (unit(hash(key, 3)) < 0.15f) {  // a gap
          x += bw + 0.05f;
          continue;
        }
        const glm::vec3 c(0.15f + 0.7f * unit(hash(key, 4)), 0.15f + 0.6f * unit(hash(key, 5)),
                          0.15f + 0.6f * unit(hash(key, 6)));
        box(f, id, {x + 0.5f * bw, boards[level] + 0.015f + 0.5f * bh, 0.02f}, {bw, bh, 0.22f}, c);
        x += bw + 0.004f;
      }
    }
  }
  // Base, column, shoulder joint, upper arm, elbow, forearm, gripper; reaching along local +x.
  void robot_arm(Frame f, float scale, glm::vec3 colour) {
    const ObjectId id = object("robot_arm");
    const glm::vec3 dark(0.2f, 0.2f, 0.22f);
    const float s = scale;
    cylinder(f, id, {0.0f, 0.0f, 0.0f}, 0.15f * s, 0.1f * s, dark);
    cylinder(f, id, {0.0f, 0.1f * s, 0.0f}, 0.065f * s, 0.45f * s, colour);
    sphere(f, id, {0.0f, 0.6f * s, 0.0f}, 0.085f * s, dark);
    box(f, id, {0.24f * s, 0.6f * s, 0.0f}, {0.42f * s, 0.08f * s, 0.08f * s}, colour);
    sphere(f, id, {0.46f * s, 0.6f * s, 0.0f}, 0.065f * s, dark);
    box(f, id, {0.46f * s, 0.43f * s, 0.0f}, {0.065f * s, 0.3f * s, 0.065f * s}, colour);
    box(f, id, {0.46f * s, 0.27f * s, 0.0f}, {0.12f * s, 0.03f * s, 0.05f * s}, dark);
    for (float sx : {-1.0f, 1.0f})
      box(f, id, {0.46f * s + sx * 0.05f * s, 0.22f * s, 0.0f}, {0.015f * s, 0.08f * s, 0.04f * s}, dark);
  }
  void lamp(Frame f, glm::vec3 shade) {
    const ObjectId id = object("lamp");
    cylinder(f, id, {0.0f, 0.0f, 0.0f}, 0.14f, 0.03f, glm::vec3(0.15f));
    cylinder(f, id, {0.0f, 0.03f, 0.0f}, 0.015f, 1.3f, glm::vec3(0.6f));
    cylinder(f, id, {0.0f, 1.3f, 0.0f}, 0.2f, 0.25f, shade, Pattern::Fabric);
  }
  // Seat facing local +z.
  void sofa(Frame f, glm::vec3 colour) {
    const ObjectId id = object("sofa");
    box(f, id, {0.0f, 0.21f, 0.0f}, {1.9f, 0.42f, 0.85f}, colour, Pattern::Fabric);
    box(f, id, {0.0f, 0.6f, -0.34f}, {1.9f, 0.38f, 0.17f}, colour * 0.9f, Pattern::Fabric);
    for (float sx : {-1.0f, 1.0f})
      box(f, id, {sx * 0.86f, 0.52f, 0.05f}, {0.18f, 0.22f, 0.75f}, colour * 0.95f, Pattern::Fabric);
  }
  // Returns the top height.
  float cabinet(Frame f, glm::vec3 size, glm::vec3 colour) {
    const ObjectId id = object("cabinet");
    box(f, id, {0.0f, 0.5f * size.y, 0.0f}, size, colour);
    box(f, id, {0.0f, 0.5f * size.y, 0.5f * size.z + 0.005f}, {size.x - 0.06f, size.y - 0.06f, 0.01f}, colour * 0.85f);
    return size.y;
  }
  void rug(Frame f, glm::vec2 size, glm::vec3 colour) {
    const ObjectId id = object("rug");
    box(f, id, {0.0f, 0.006f, 0.0f}, {size.x, 0.012f, size.y}, colour, Pattern::Fabric);
  }

 private:
  Room& room_;
};

Frame on(float x, float y, float z, float yaw = 0.0f) { return Frame{{x, y, z}, yaw}; }

void variant0(Builder& b) {
  b.shell({6.0f, 2.8f, 5.0f}, {0.86f, 0.83f, 0.76f}, {0.56f, 0.38f, 0.22f}, Pattern::Planks);
  const float top = b.table(on(0.3f, 0.0f, 0.2f), {1.6f, 0.9f}, 0.75f, {0.5f, 0.33f, 0.2f});
  b.chair(on(0.0f, 0.0f, -0.55f), {0.2f, 0.3f, 0.55f}, glm::vec3(0.25f));
  b.chair(on(0.6f, 0.0f, 0.95f, kPi), {0.2f, 0.3f, 0.55f}, glm::vec3(0.25f));
  b.keyboard(on(0.25f, top, 0.05f));
  b.monitor(on(0.3f, top, 0.45f, kPi));
  b.plant(on(-2.5f, 0.0f, -2.0f), 1.0f, {0.7f, 0.36f, 0.2f}, {0.2f, 0.5f, 0.18f});
  b.shelf(on(1.6f, 0.0f, -2.5f + 0.17f), {0.62f, 0.45f, 0.28f}, 101);
  b.robot_arm(on(-1.8f, 0.0f, 1.5f, 0.6f), 1.0f, {0.92f, 0.45f, 0.1f});
}

void variant1(Builder& b) {
  b.shell({5.0f, 2.7f, 4.5f}, {0.7f, 0.78f, 0.86f}, {0.75f, 0.73f, 0.7f}, Pattern::Tiles);
  const float top = b.table(on(-0.4f, 0.0f, -0.3f, 0.3f), {1.3f, 0.8f}, 0.74f, {0.82f, 0.8f, 0.76f});
  b.chair(on(-0.55f, 0.0f, -0.95f, 0.3f), {0.75f, 0.25f, 0.2f}, glm::vec3(0.7f));
  b.chair(on(-0.25f, 0.0f, 0.35f, 0.3f + kPi), {0.75f, 0.25f, 0.2f}, glm::vec3(0.7f));
  b.chair(on(0.55f, 0.0f, -0.1f, 0.3f - 0.5f * kPi), {0.2f, 0.55f, 0.3f}, glm::vec3(0.7f));
  b.keyboard(on(-0.45f, top, -0.4f, 0.3f));
  b.plant(on(2.05f, 0.0f, 1.75f), 1.2f, {0.85f, 0.85f, 0.82f}, {0.25f, 0.55f, 0.2f});
  b.shelf(on(-2.5f + 0.17f, 0.0f, 0.9f, 0.5f * kPi), {0.3f, 0.22f, 0.16f}, 202);
  const float ctop = b.cabinet(on(1.6f, 0.0f, -1.9f), {0.8f, 0.7f, 0.5f}, {0.55f, 0.57f, 0.6f});
  b.robot_arm(on(1.45f, ctop, -1.95f, 2.2f), 0.8f, {0.95f, 0.8f, 0.15f});
  b.lamp(on(2.1f, 0.0f, -0.2f), {0.95f, 0.9f, 0.75f});
}

void variant2(Builder& b) {
  b.shell({7.0f, 3.0f, 6.0f}, {0.9f, 0.88f, 0.84f}, {0.38f, 0.25f, 0.15f}, Pattern::Planks);
  b.rug(on(0.0f, 0.0f, 0.3f), {2.6f, 2.0f}, {0.6f, 0.2f, 0.2f});
  const float top = b.table(on(0.0f, 0.0f, 0.3f), {1.8f, 1.0f}, 0.76f, {0.3f, 0.2f, 0.12f});
  b.chair(on(-0.45f, 0.0f, -0.45f), {0.85f, 0.85f, 0.8f}, glm::vec3(0.15f));
  b.chair(on(0.45f, 0.0f, -0.45f), {0.85f, 0.85f, 0.8f}, glm::vec3(0.15f));
  b.chair(on(-0.45f, 0.0f, 1.05f, kPi), {0.85f, 0.85f, 0.8f}, glm::vec3(0.15f));
  b.chair(on(0.45f, 0.0f, 1.05f, kPi), {0.85f, 0.85f, 0.8f}, glm::vec3(0.15f));
  b.keyboard(on(-0.3f, top, 0.2f, 0.2f));
  b.monitor(on(0.2f, top, 0.55f, kPi));
  b.sofa(on(0.0f, 0.0f, -2.55f), {0.3f, 0.42f, 0.35f});
  b.plant(on(-3.0f, 0.0f, -2.5f), 1.3f, {0.3f, 0.3f, 0.32f}, {0.18f, 0.45f, 0.15f});
  b.plant(on(3.0f, 0.0f, 2.5f), 0.9f, {0.7f, 0.36f, 0.2f}, {0.3f, 0.55f, 0.2f});
  b.shelf(on(-1.5f, 0.0f, 3.0f - 0.17f, kPi), {0.62f, 0.45f, 0.28f}, 303);
  b.shelf(on(3.5f - 0.17f, 0.0f, -0.5f, -0.5f * kPi), {0.9f, 0.9f, 0.88f}, 304);
  b.robot_arm(on(2.2f, 0.0f, 1.6f, 2.5f), 1.1f, {0.85f, 0.85f, 0.9f});
  b.lamp(on(-3.0f, 0.0f, 1.0f), {0.9f, 0.6f, 0.3f});
}

void variant3(Builder& b) {
  b.shell({4.2f, 2.6f, 3.8f}, {0.92f, 0.86f, 0.7f}, {0.65f, 0.62f, 0.58f}, Pattern::Tiles);
  const float top = b.table(on(0.0f, 0.0f, -1.9f + 0.4f), {1.6f, 0.7f}, 0.73f, {0.9f, 0.9f, 0.88f});
  b.chair(on(-0.35f, 0.0f, -0.75f, kPi), {0.15f, 0.15f, 0.15f}, glm::vec3(0.5f));
  b.chair(on(1.3f, 0.0f, 0.4f, -2.4f), {0.5f, 0.2f, 0.45f}, glm::vec3(0.5f));
  b.keyboard(on(-0.3f, top, -1.35f));
  b.monitor(on(-0.3f, top, -1.7f));
  b.robot_arm(on(0.55f, top, -1.6f, 1.9f), 0.6f, {0.2f, 0.45f, 0.85f});
  b.plant(on(-1.75f, 0.0f, 1.5f), 0.8f, {0.9f, 0.9f, 0.9f}, {0.22f, 0.5f, 0.2f});
  b.shelf(on(2.1f - 0.17f, 0.0f, -0.7f, -0.5f * kPi), {0.45f, 0.3f, 0.2f}, 405);
  b.cabinet(on(-1.6f, 0.0f, -1.65f), {0.6f, 0.9f, 0.45f}, {0.4f, 0.42f, 0.45f});
}

}  // namespace

Room build_room(int variant) {
  Room room;
  Builder b(room);
  switch (variant) {
    case 1: variant1(b); break;
    case 2: variant2(b); break;
    case 3: variant3(b); break;
    default: variant0(b); break;
  }
  // Group consecutive primitives of one object (the builders add an object's parts together).
  for (std::size_t i = 0; i < room.primitives.size(); ++i) {
    glm::vec3 lo, hi;
    primitive_bounds(room.primitives[i], lo, hi);
    const bool same = !room.groups.empty() && i > 1 && room.primitives[i].object == room.primitives[i - 1].object;
    if (!same) room.groups.push_back({static_cast<int>(i), 0, lo, hi});
    PrimitiveGroup& g = room.groups.back();
    ++g.count;
    g.min = glm::min(g.min, lo);
    g.max = glm::max(g.max, hi);
  }
  return room;
}

}  // namespace gauss::scene
