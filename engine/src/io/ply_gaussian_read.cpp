// 3DGS PLY reader: a per-property decode plan is built once from the header, then every
// vertex runs the same flat list of steps (no name lookups per vertex).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "gauss/engine/kept_file_indices.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/quaternion.h"
#include "io/file_bytes.h"
#include "io/memory_room.h"
#include "io/ply_core.h"
#include "io/splat_quantized.h"  // alpha_to_logit: the saturated opacity logit

namespace gauss {
namespace {

using ply::Element;
using ply::Header;
using ply::Property;
using ply::Scalar;

// Float slots of one decoded vertex, in a fixed order independent of the file's order.
constexpr int kSlotPos = 0;      // x y z
constexpr int kSlotDc = 3;       // f_dc_0..2
constexpr int kSlotOpacity = 6;  // opacity
constexpr int kSlotScale = 7;    // scale_0..2
constexpr int kSlotRot = 10;     // rot_0..3
constexpr int kSlotRest = 14;    // f_rest_0..44 (file order, channel-major)
constexpr int kMaxRestProps = 3 * kMaxShRest;
constexpr int kFloatSlots = kSlotRest + kMaxRestProps;

enum class Kind : std::uint8_t { Ignore, Float, ObjectId, GaussianIdProp, Support };

struct Step {
  Kind kind{Kind::Ignore};
  std::uint8_t slot{0};
};

struct Plan {
  std::vector<Step> steps;  // one per vertex property, in file order
  int rest_props{0};
  int degree{0};
};

// "prefix<digits>" -> index, or -1 when `s` is not of that form (leading zeros rejected so
// "f_rest_01" cannot alias "f_rest_1").
int suffix_index(std::string_view s, std::string_view prefix) {
  if (s.size() <= prefix.size() || s.substr(0, prefix.size()) != prefix) return -1;
  const std::string_view digits = s.substr(prefix.size());
  if (digits.size() > 4 || (digits.size() > 1 && digits[0] == '0')) return -1;
  int v = 0;
  for (char c : digits) {
    if (c < '0' || c > '9') return -1;
    v = v * 10 + (c - '0');
  }
  return v;
}

Expected<Plan> make_plan(const Element& v, std::string_view name, PlyGaussianReport& report) {
  Plan plan;
  plan.steps.resize(v.properties.size());
  std::array<bool, kFloatSlots> seen{};
  std::array<const char*, kSlotRest> required_names{"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                                                    "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2",
                                                    "rot_3"};
  int normals = 0;
  for (std::size_t k = 0; k < v.properties.size(); ++k) {
    const Property& p = v.properties[k];
    Step step;
    int slot = -1;
    for (int r = 0; r < kSlotRest; ++r)
      if (p.name == required_names[static_cast<std::size_t>(r)]) slot = r;
    if (slot < 0) {
      const int rest = suffix_index(p.name, "f_rest_");
      if (rest >= kMaxRestProps)
        return ply::make_error(name, "vertex property '" + p.name + "' (header line " + std::to_string(p.header_line) +
                                         ") is beyond SH degree 3 (at most f_rest_" +
                                         std::to_string(kMaxRestProps - 1) + ")");
      if (rest >= 0) slot = kSlotRest + rest;
    }
    if (slot >= 0) {
      step.kind = Kind::Float;
      step.slot = static_cast<std::uint8_t>(slot);
      seen[static_cast<std::size_t>(slot)] = true;
    } else if (p.name == "object_id") {
      step.kind = Kind::ObjectId;
      report.has_object_id = true;
    } else if (p.name == "gaussian_id") {
      step.kind = Kind::GaussianIdProp;
      report.has_gaussian_id = true;
    } else if (p.name == "support") {
      step.kind = Kind::Support;
      report.has_support = true;
    } else if (p.name == "nx" || p.name == "ny" || p.name == "nz") {
      ++normals;
    } else {
      report.ignored_properties.push_back(p.name);
    }
    if (step.kind != Kind::Ignore && p.is_list)
      return ply::make_error(name, "vertex property '" + p.name + "' (header line " + std::to_string(p.header_line) +
                                       ") is a list; expected a single value");
    plan.steps[k] = step;
  }
  report.has_normals = normals == 3;
  for (int r = 0; r < kSlotRest; ++r)
    if (!seen[static_cast<std::size_t>(r)])
      return ply::make_error(name, "missing required vertex property '" +
                                       std::string(required_names[static_cast<std::size_t>(r)]) + "'");
  int rest = 0;
  for (int r = 0; r < kMaxRestProps; ++r) rest += seen[static_cast<std::size_t>(kSlotRest + r)] ? 1 : 0;
  int degree = -1;
  for (int d = 0; d <= kMaxShDegree; ++d)
    if (rest == 3 * sh_rest_count(d)) degree = d;
  if (degree < 0)
    return ply::make_error(name, "found " + std::to_string(rest) +
                                     " f_rest properties; expected 0, 9, 24 or 45 (SH degree 0..3)");
  for (int r = 0; r < rest; ++r)
    if (!seen[static_cast<std::size_t>(kSlotRest + r)])
      return ply::make_error(name, "missing vertex property 'f_rest_" + std::to_string(r) + "' (found " +
                                       std::to_string(rest) + " f_rest properties, expected f_rest_0..f_rest_" +
                                       std::to_string(rest - 1) + ")");
  plan.rest_props = rest;
  plan.degree = degree;
  return plan;
}

std::string describe(float f) {
  if (std::isnan(f)) return "NaN";
  return f > 0 ? "+Inf" : "-Inf";
}

template <class Reader>
Status decode_vertices(Reader& r, const Element& v, const Plan& plan, std::string_view name,
                       std::vector<Gaussian>& out, PlyGaussianReport& report) {
  const std::size_t count = static_cast<std::size_t>(v.count);
  if (auto s = io::resize_cloud(out, count, name); !s) return s;
  const int coefs = plan.rest_props / 3;
  std::array<float, kFloatSlots> vals{};
  Scalar s;
  std::string why;
  auto where = [&](std::size_t vertex, const Property& p) {
    return "vertex " + std::to_string(vertex) + ", property '" + p.name + "' (" + r.where() + ")";
  };
  auto fail = [&](std::size_t vertex, const Property& p, const std::string& what) {
    return ply::make_error(name, where(vertex, p) + ": " + what);
  };
  // Vertices with a non-finite value are left out (a trainer that diverged, a converter's
  // overflow), the rest kept in file order at out[0, kept); an infinite opacity logit is a
  // saturated opacity, clamped as the 8-bit formats clamp theirs.
  const float saturated = io::alpha_to_logit(1.0);
  std::size_t kept = 0;
  bool slot_dirty = false;  // out[kept] holds fields of a vertex that was left out
  for (std::size_t i = 0; i < count; ++i) {
    if (slot_dirty) out[kept] = Gaussian{};
    Gaussian& g = out[kept];
    g.id = GaussianId{i};  // the file index, unless a gaussian_id property says otherwise
    bool non_finite = false;
    std::size_t clamped = 0;
    if (!r.begin_item())
      return ply::make_error(name, "vertex " + std::to_string(i) + " (" + r.where() + "): " + r.error());
    for (std::size_t k = 0; k < plan.steps.size(); ++k) {
      const Property& p = v.properties[k];
      const Step step = plan.steps[k];
      if (p.is_list) {  // only ignored properties can be lists (checked in make_plan)
        std::uint64_t n = 0;
        if (!r.read(p.count_type, s)) return fail(i, p, r.error());
        if (!ply::to_uint64(s, n, why)) return fail(i, p, "bad list length: " + why);
        for (std::uint64_t e = 0; e < n; ++e)
          if (!r.read(p.type, s)) return fail(i, p, r.error());
        continue;
      }
      if (!r.read(p.type, s)) return fail(i, p, r.error());
      switch (step.kind) {
        case Kind::Ignore: break;
        case Kind::Float: {
          float f = 0.0f;
          if (!ply::to_float(s, f, why)) return fail(i, p, why);
          if (std::isinf(f) && step.slot == kSlotOpacity) {
            f = f > 0 ? saturated : -saturated;
            ++clamped;
          } else if (!std::isfinite(f)) {
            if (!non_finite && report.first_dropped.empty())
              report.first_dropped = where(i, p) + ": value is " + describe(f);
            non_finite = true;
          }
          vals[step.slot] = f;
          break;
        }
        case Kind::ObjectId: {
          std::int64_t id = 0;
          if (!ply::to_int64(s, id, why)) return fail(i, p, why);
          if (id < -1 || id > std::numeric_limits<std::int32_t>::max())
            return fail(i, p, "object id " + std::to_string(id) + " is out of range (-1 = none, else 0..2^31-1)");
          g.object = ObjectId{static_cast<std::int32_t>(id)};
          break;
        }
        case Kind::GaussianIdProp: {
          std::uint64_t id = 0;
          if (!ply::to_uint64(s, id, why)) return fail(i, p, why);
          g.id = GaussianId{id};
          break;
        }
        case Kind::Support: {
          std::uint64_t n = 0;
          if (!ply::to_uint64(s, n, why)) return fail(i, p, why);
          if (n > std::numeric_limits<std::uint32_t>::max())
            return fail(i, p, "support " + std::to_string(n) + " exceeds 2^32-1");
          g.support = static_cast<std::uint32_t>(n);
          break;
        }
      }
    }
    if (!r.end_item()) return ply::make_error(name, "vertex " + std::to_string(i) + ": " + r.error());
    slot_dirty = non_finite;
    if (non_finite) {
      report.dropped_vertices.push_back(i);
      continue;
    }
    report.saturated_opacities += clamped;
    ++kept;
    g.position = glm::vec3(vals[kSlotPos], vals[kSlotPos + 1], vals[kSlotPos + 2]);
    g.sh_dc = glm::vec3(vals[kSlotDc], vals[kSlotDc + 1], vals[kSlotDc + 2]);
    g.opacity_logit = vals[kSlotOpacity];
    g.log_scale = glm::vec3(vals[kSlotScale], vals[kSlotScale + 1], vals[kSlotScale + 2]);
    g.rotation = glm::vec4(vals[kSlotRot], vals[kSlotRot + 1], vals[kSlotRot + 2], vals[kSlotRot + 3]);
    // f_rest is channel-major in the file: f_rest_{c * coefs + k} is coefficient k+1 of channel c.
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < coefs; ++k)
        g.sh_rest[static_cast<std::size_t>(k)][c] = vals[static_cast<std::size_t>(kSlotRest + c * coefs + k)];
  }
  if (count > 0 && kept == 0)
    return ply::make_error(name, "every one of its " + std::to_string(count) +
                                     " vertices has a non-finite value (the first: " + report.first_dropped + ")");
  out.resize(kept);
  return Ok{};
}

template <class Reader>
Status read_elements(Reader& r, const Header& h, const Element& vertex, const Plan& plan, std::string_view name,
                     std::vector<Gaussian>& out, PlyGaussianReport& report) {
  for (const auto& e : h.elements) {
    const Status st = &e == &vertex ? decode_vertices(r, e, plan, name, out, report) : ply::skip_element(r, e, name);
    if (!st) return st;
  }
  if (!r.at_end()) return ply::make_error(name, r.trailing());
  return Ok{};
}

// Normalises rotations (see the header for the rule) and counts what changed.
void normalize_rotations(std::vector<Gaussian>& gs, PlyGaussianReport& report) {
  for (auto& g : gs) {
    const glm::vec4 q = g.rotation;
    const double n2 = double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3];
    if (std::abs(std::sqrt(n2) - 1.0) <= kQuaternionUnitTolerance) continue;
    const auto result = normalize_quaternion(g.rotation);
    if (result == QuaternionNormalization::ZeroReplacedByIdentity)
      ++report.zero_quaternions;
    else
      ++report.renormalized_quaternions;
  }
}

Status check_unique_ids(const std::vector<Gaussian>& gs, std::span<const std::size_t> dropped, std::string_view name) {
  std::vector<std::pair<std::uint64_t, std::size_t>> ids(gs.size());
  KeptFileIndices vertex(dropped);  // messages name the file's vertex
  for (std::size_t i = 0; i < gs.size(); ++i) ids[i] = {to_underlying(gs[i].id), vertex.next()};
  std::sort(ids.begin(), ids.end());
  for (std::size_t i = 1; i < ids.size(); ++i)
    if (ids[i].first == ids[i - 1].first)
      return ply::make_error(name, "gaussian_id " + std::to_string(ids[i].first) + " appears at vertex " +
                                       std::to_string(ids[i - 1].second) + " and vertex " +
                                       std::to_string(ids[i].second) + " (ids must be unique)");
  return Ok{};
}

}  // namespace

Expected<PlyGaussianScene> parse_gaussian_ply(std::span<const std::uint8_t> bytes, std::string_view name) {
  auto header = ply::parse_header(bytes, name);
  if (!header) return header.error();
  const Header& h = *header;
  const Element* vertex = h.find("vertex");
  if (!vertex) return ply::make_error(name, "no 'vertex' element");

  PlyGaussianScene scene;
  PlyGaussianReport& report = scene.report;
  report.format = h.format;
  report.vertex_count = static_cast<std::size_t>(vertex->count);
  for (const auto& e : h.elements)
    if (&e != vertex) report.ignored_elements.push_back(e.name);
  auto plan = make_plan(*vertex, name, report);
  if (!plan) return plan.error();
  report.sh_degree = plan->degree;

  std::vector<Gaussian>& gs = scene.cloud.gaussians;
  Status st = Ok{};
  if (h.format == PlyFormat::Ascii) {
    ply::AsciiReader r(bytes, h.data_offset, h.data_line);
    st = read_elements(r, h, *vertex, *plan, name, gs, report);
  } else {
    ply::BinaryReader r(bytes, h.data_offset, h.format == PlyFormat::BinaryBigEndian);
    st = read_elements(r, h, *vertex, *plan, name, gs, report);
  }
  if (!st) return st.error();

  if (report.has_gaussian_id)  // else each id is its vertex's index in the file (decode_vertices)
    if (Status u = check_unique_ids(gs, report.dropped_vertices, name); !u) return u.error();
  normalize_rotations(gs, report);
  scene.cloud.sh_degree = plan->degree;
  return scene;
}

Expected<PlyGaussianScene> read_gaussian_ply(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  return parse_gaussian_ply(*bytes, path.string());
}

}  // namespace gauss
