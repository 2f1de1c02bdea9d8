// Mesh PLY reader/writer: coloured vertices and polygon faces (fanned into triangles).
#include "gauss/engine/ply_mesh.h"

#include <cmath>
#include <limits>
#include <string>

#include "io/file_bytes.h"
#include "io/ply_core.h"

namespace gauss {
namespace {

using ply::Element;
using ply::Header;
using ply::Property;
using ply::Scalar;
using ply::Type;

struct MeshPlan {
  const Element* vertex{nullptr};
  const Element* face{nullptr};
  int pos[3]{-1, -1, -1};
  int color[3]{-1, -1, -1};
  int indices{-1};
};

Expected<MeshPlan> make_plan(const Header& h, std::string_view name) {
  MeshPlan plan;
  plan.vertex = h.find("vertex");
  if (!plan.vertex) return ply::make_error(name, "no 'vertex' element");
  const Element& v = *plan.vertex;
  const char* pos_names[3] = {"x", "y", "z"};
  const char* color_names[3] = {"red", "green", "blue"};
  for (int k = 0; k < 3; ++k) {
    plan.pos[k] = v.find(pos_names[k]);
    if (plan.pos[k] < 0) return ply::make_error(name, std::string("missing required vertex property '") + pos_names[k] + "'");
    plan.color[k] = v.find(color_names[k]);
  }
  const int colors = (plan.color[0] >= 0) + (plan.color[1] >= 0) + (plan.color[2] >= 0);
  if (colors != 0 && colors != 3)
    return ply::make_error(name, "vertex colours need all of 'red', 'green', 'blue'; found only " +
                                     std::to_string(colors) + " of them");
  for (int k = 0; k < 3; ++k) {
    for (int idx : {plan.pos[k], plan.color[k]}) {
      if (idx < 0) continue;
      const Property& p = v.properties[static_cast<std::size_t>(idx)];
      if (p.is_list)
        return ply::make_error(name, "vertex property '" + p.name + "' is a list; expected a single value");
    }
  }
  plan.face = h.find("face");
  if (plan.face) {
    plan.indices = plan.face->find("vertex_indices");
    if (plan.indices < 0) plan.indices = plan.face->find("vertex_index");
    if (plan.indices < 0) return ply::make_error(name, "element 'face' has no 'vertex_indices' list");
    const Property& p = plan.face->properties[static_cast<std::size_t>(plan.indices)];
    if (!p.is_list) return ply::make_error(name, "face property '" + p.name + "' is not a list");
    if (ply::is_float_type(p.type))
      return ply::make_error(name, "face property '" + p.name + "' has item type " +
                                       std::string(ply::type_name(p.type)) + "; expected an integer type");
  }
  return plan;
}

template <class Reader>
Status decode_vertices(Reader& r, const MeshPlan& plan, std::string_view name, TriangleMesh& mesh) {
  const Element& v = *plan.vertex;
  const std::size_t count = static_cast<std::size_t>(v.count);
  mesh.positions.resize(count);
  mesh.colors.assign(count, glm::u8vec3(255));
  Scalar s;
  std::string why;
  for (std::size_t i = 0; i < count; ++i) {
    auto fail = [&](const Property& p, const std::string& what) {
      return ply::make_error(name, "vertex " + std::to_string(i) + ", property '" + p.name + "' (" + r.where() +
                                       "): " + what);
    };
    if (!r.begin_item()) return ply::make_error(name, "vertex " + std::to_string(i) + " (" + r.where() + "): " + r.error());
    for (std::size_t k = 0; k < v.properties.size(); ++k) {
      const Property& p = v.properties[k];
      if (p.is_list) {
        std::uint64_t n = 0;
        if (!r.read(p.count_type, s)) return fail(p, r.error());
        if (!ply::to_uint64(s, n, why)) return fail(p, "bad list length: " + why);
        for (std::uint64_t e = 0; e < n; ++e)
          if (!r.read(p.type, s)) return fail(p, r.error());
        continue;
      }
      if (!r.read(p.type, s)) return fail(p, r.error());
      const int idx = static_cast<int>(k);
      for (int c = 0; c < 3; ++c) {
        if (idx == plan.pos[c]) {
          float f = 0.0f;
          if (!ply::to_float(s, f, why)) return fail(p, why);
          if (!std::isfinite(f)) return fail(p, std::isnan(f) ? "value is NaN (must be finite)" : "value is Inf (must be finite)");
          mesh.positions[i][c] = f;
        } else if (idx == plan.color[c]) {
          std::uint64_t u = 0;
          if (!ply::to_uint64(s, u, why)) return fail(p, why);
          if (u > 255) return fail(p, "colour " + std::to_string(u) + " is outside 0..255");
          mesh.colors[i][c] = static_cast<std::uint8_t>(u);
        }
      }
    }
    if (!r.end_item()) return ply::make_error(name, "vertex " + std::to_string(i) + ": " + r.error());
  }
  return Ok{};
}

template <class Reader>
Status decode_faces(Reader& r, const MeshPlan& plan, std::string_view name, TriangleMesh& mesh, PlyMeshReport& report) {
  const Element& f = *plan.face;
  const std::uint64_t vertex_count = plan.vertex->count;
  const std::size_t count = static_cast<std::size_t>(f.count);
  mesh.indices.reserve(count * 3);
  std::vector<std::uint32_t> poly;
  Scalar s;
  std::string why;
  for (std::size_t i = 0; i < count; ++i) {
    auto fail = [&](const Property& p, const std::string& what) {
      return ply::make_error(name, "face " + std::to_string(i) + ", property '" + p.name + "' (" + r.where() +
                                       "): " + what);
    };
    if (!r.begin_item()) return ply::make_error(name, "face " + std::to_string(i) + " (" + r.where() + "): " + r.error());
    for (std::size_t k = 0; k < f.properties.size(); ++k) {
      const Property& p = f.properties[k];
      if (!p.is_list) {
        if (!r.read(p.type, s)) return fail(p, r.error());
        continue;
      }
      std::uint64_t n = 0;
      if (!r.read(p.count_type, s)) return fail(p, r.error());
      if (!ply::to_uint64(s, n, why)) return fail(p, "bad list length: " + why);
      const bool is_indices = static_cast<int>(k) == plan.indices;
      if (is_indices && n < 3) return fail(p, "polygon has " + std::to_string(n) + " vertices (at least 3 needed)");
      poly.clear();
      for (std::uint64_t e = 0; e < n; ++e) {
        if (!r.read(p.type, s)) return fail(p, r.error());
        if (!is_indices) continue;
        std::int64_t idx = 0;
        if (!ply::to_int64(s, idx, why)) return fail(p, why);
        if (idx < 0 || static_cast<std::uint64_t>(idx) >= vertex_count)
          return fail(p, "index " + std::to_string(idx) + " is out of range (the mesh has " +
                             std::to_string(vertex_count) + " vertices)");
        poly.push_back(static_cast<std::uint32_t>(idx));
      }
      if (!is_indices) continue;
      // Fan (0, j, j+1): a quad becomes two triangles, winding kept.
      for (std::size_t j = 1; j + 1 < poly.size(); ++j) {
        mesh.indices.push_back(poly[0]);
        mesh.indices.push_back(poly[j]);
        mesh.indices.push_back(poly[j + 1]);
      }
      if (poly.size() > 3) ++report.split_polygons;
    }
    if (!r.end_item()) return ply::make_error(name, "face " + std::to_string(i) + ": " + r.error());
  }
  report.polygon_count = count;
  return Ok{};
}

template <class Reader>
Status read_elements(Reader& r, const Header& h, const MeshPlan& plan, std::string_view name, PlyMeshScene& out) {
  for (const auto& e : h.elements) {
    Status st = Ok{};
    if (&e == plan.vertex)
      st = decode_vertices(r, plan, name, out.mesh);
    else if (&e == plan.face)
      st = decode_faces(r, plan, name, out.mesh, out.report);
    else
      st = ply::skip_element(r, e, name);
    if (!st) return st;
  }
  if (!r.at_end()) return ply::make_error(name, r.trailing());
  return Ok{};
}

void put_text_u(std::string& out, std::uint64_t v) { ply::put_text(out, v); }

}  // namespace

Expected<PlyMeshScene> parse_mesh_ply(std::span<const std::uint8_t> bytes, std::string_view name) {
  auto header = ply::parse_header(bytes, name);
  if (!header) return header.error();
  auto plan = make_plan(*header, name);
  if (!plan) return plan.error();
  PlyMeshScene scene;
  scene.report.format = header->format;
  scene.report.has_colors = plan->color[0] >= 0;
  Status st = Ok{};
  if (header->format == PlyFormat::Ascii) {
    ply::AsciiReader r(bytes, header->data_offset, header->data_line);
    st = read_elements(r, *header, *plan, name, scene);
  } else {
    ply::BinaryReader r(bytes, header->data_offset, header->format == PlyFormat::BinaryBigEndian);
    st = read_elements(r, *header, *plan, name, scene);
  }
  if (!st) return st.error();
  return scene;
}

Expected<PlyMeshScene> read_mesh_ply(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  return parse_mesh_ply(*bytes, path.string());
}

Expected<std::vector<std::uint8_t>> encode_mesh_ply(const TriangleMesh& mesh, const PlyMeshWriteOptions& o) {
  const std::size_t nv = mesh.positions.size();
  if (!mesh.colors.empty() && mesh.colors.size() != nv)
    return Error{"cannot write a mesh PLY: " + std::to_string(mesh.colors.size()) + " colours for " +
                 std::to_string(nv) + " vertices"};
  if (mesh.indices.size() % 3 != 0)
    return Error{"cannot write a mesh PLY: " + std::to_string(mesh.indices.size()) +
                 " indices is not a multiple of 3"};
  if (nv > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    return Error{"cannot write a mesh PLY: " + std::to_string(nv) + " vertices exceed the int index range"};
  for (std::size_t i = 0; i < nv; ++i)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(mesh.positions[i][c]))
        return Error{"cannot write a mesh PLY: vertex " + std::to_string(i) + " has a non-finite position"};
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= nv)
      return Error{"cannot write a mesh PLY: index " + std::to_string(i) + " (" + std::to_string(mesh.indices[i]) +
                   ") is out of range for " + std::to_string(nv) + " vertices"};

  Element v;
  v.name = "vertex";
  v.count = nv;
  for (const char* n : {"x", "y", "z"}) v.properties.push_back({n, Type::Float32, false, Type::UInt8, 0});
  for (const char* n : {"red", "green", "blue"}) v.properties.push_back({n, Type::UInt8, false, Type::UInt8, 0});
  Element f;
  f.name = "face";
  f.count = mesh.indices.size() / 3;
  f.properties.push_back({"vertex_indices", Type::Int32, true, Type::UInt8, 0});
  std::string header;
  ply::write_header(header, o.format, {v, f}, "GaussAnything mesh");
  std::vector<std::uint8_t> out(header.begin(), header.end());
  auto color = [&](std::size_t i) { return mesh.colors.empty() ? glm::u8vec3(255) : mesh.colors[i]; };

  if (o.format == PlyFormat::Ascii) {
    std::string text;
    for (std::size_t i = 0; i < nv; ++i) {
      for (int c = 0; c < 3; ++c) {
        ply::put_text(text, mesh.positions[i][c]);
        text += ' ';
      }
      const glm::u8vec3 col = color(i);
      for (int c = 0; c < 3; ++c) {
        put_text_u(text, col[c]);
        text += c < 2 ? ' ' : '\n';
      }
    }
    for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
      text += '3';
      for (int c = 0; c < 3; ++c) {
        text += ' ';
        put_text_u(text, mesh.indices[t + static_cast<std::size_t>(c)]);
      }
      text += '\n';
    }
    out.insert(out.end(), text.begin(), text.end());
    return out;
  }
  const bool be = o.format == PlyFormat::BinaryBigEndian;
  out.reserve(out.size() + nv * 15 + mesh.indices.size() / 3 * 13);
  for (std::size_t i = 0; i < nv; ++i) {
    for (int c = 0; c < 3; ++c) ply::put_float(out, mesh.positions[i][c], be);
    const glm::u8vec3 col = color(i);
    for (int c = 0; c < 3; ++c) ply::put_u8(out, col[c]);
  }
  for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
    ply::put_u8(out, 3);
    for (std::size_t c = 0; c < 3; ++c) ply::put_i32(out, static_cast<std::int32_t>(mesh.indices[t + c]), be);
  }
  return out;
}

Status write_mesh_ply(const std::filesystem::path& path, const TriangleMesh& mesh, const PlyMeshWriteOptions& options) {
  auto bytes = encode_mesh_ply(mesh, options);
  if (!bytes) return Error{path.string() + ": " + bytes.message()};
  return io::write_file_atomic(path, *bytes);
}

}  // namespace gauss
