// 3DGS PLY writer: the INRIA property order, then the optional id/label/support columns.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "gauss/engine/ply_gaussian.h"
#include "io/file_bytes.h"
#include "io/ply_core.h"

namespace gauss {
namespace {

using ply::Element;
using ply::Property;
using ply::Type;

// The float columns of one Gaussian in file order; returns how many were filled.
int gather_floats(const Gaussian& g, int coefs, bool normals, std::array<float, 62>& v) {
  int n = 0;
  for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(n++)] = g.position[k];
  if (normals)
    for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(n++)] = 0.0f;
  for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(n++)] = g.sh_dc[k];
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < coefs; ++k) v[static_cast<std::size_t>(n++)] = g.sh_rest[static_cast<std::size_t>(k)][c];
  v[static_cast<std::size_t>(n++)] = g.opacity_logit;
  for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(n++)] = g.log_scale[k];
  for (int k = 0; k < 4; ++k) v[static_cast<std::size_t>(n++)] = g.rotation[k];
  return n;
}

Status validate(const GaussianCloud& cloud, const PlyGaussianWriteOptions& o, const std::vector<Property>& props) {
  if (cloud.sh_degree < 0 || cloud.sh_degree > kMaxShDegree)
    return Error{"cannot write a Gaussian PLY: SH degree " + std::to_string(cloud.sh_degree) + " is outside 0..3"};
  const int coefs = sh_rest_count(cloud.sh_degree);
  std::array<float, 62> v{};
  for (std::size_t i = 0; i < cloud.gaussians.size(); ++i) {
    const Gaussian& g = cloud.gaussians[i];
    const int n = gather_floats(g, coefs, o.write_normals, v);
    for (int k = 0; k < n; ++k)
      if (!std::isfinite(v[static_cast<std::size_t>(k)]))
        return Error{"cannot write a Gaussian PLY: Gaussian " + std::to_string(i) + " has a non-finite '" +
                     props[static_cast<std::size_t>(k)].name + "'"};
    if (o.write_object_id && to_underlying(g.object) < -1)
      return Error{"cannot write a Gaussian PLY: Gaussian " + std::to_string(i) + " has object id " +
                   std::to_string(to_underlying(g.object)) + " (valid: -1 = none, or >= 0)"};
  }
  if (o.write_gaussian_id) {
    std::vector<std::uint64_t> ids(cloud.gaussians.size());
    for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = to_underlying(cloud.gaussians[i].id);
    std::sort(ids.begin(), ids.end());
    const auto dup = std::adjacent_find(ids.begin(), ids.end());
    if (dup != ids.end())
      return Error{"cannot write a Gaussian PLY: gaussian_id " + std::to_string(*dup) +
                   " is used by more than one Gaussian"};
  }
  return Ok{};
}

}  // namespace

Expected<std::vector<std::uint8_t>> encode_gaussian_ply(const GaussianCloud& cloud,
                                                        const PlyGaussianWriteOptions& o) {
  const int degree = std::clamp(cloud.sh_degree, 0, kMaxShDegree);
  const int coefs = sh_rest_count(degree);
  Element e;
  e.name = "vertex";
  e.count = cloud.gaussians.size();
  auto add = [&](std::string n, Type t) {
    Property p;
    p.name = std::move(n);
    p.type = t;
    e.properties.push_back(std::move(p));
  };
  for (const char* n : {"x", "y", "z"}) add(n, Type::Float32);
  if (o.write_normals)
    for (const char* n : {"nx", "ny", "nz"}) add(n, Type::Float32);
  for (const char* n : {"f_dc_0", "f_dc_1", "f_dc_2"}) add(n, Type::Float32);
  for (int k = 0; k < 3 * coefs; ++k) add("f_rest_" + std::to_string(k), Type::Float32);
  add("opacity", Type::Float32);
  for (const char* n : {"scale_0", "scale_1", "scale_2"}) add(n, Type::Float32);
  for (const char* n : {"rot_0", "rot_1", "rot_2", "rot_3"}) add(n, Type::Float32);
  const std::size_t float_props = e.properties.size();
  if (Status st = validate(cloud, o, e.properties); !st) return st.error();

  bool wide_ids = false;  // uint64 only when needed: most PLY tools know no 64-bit type
  if (o.write_gaussian_id)
    for (const auto& g : cloud.gaussians) wide_ids |= to_underlying(g.id) > 0xFFFFFFFFull;
  if (o.write_object_id) add("object_id", Type::Int32);
  if (o.write_gaussian_id) add("gaussian_id", wide_ids ? Type::UInt64 : Type::UInt32);
  if (o.write_support) add("support", Type::UInt32);

  std::string header;
  ply::write_header(header, o.format, {e}, "GaussAnything 3DGS scene");
  std::vector<std::uint8_t> out(header.begin(), header.end());
  std::array<float, 62> v{};

  if (o.format == PlyFormat::Ascii) {
    std::string text;
    text.reserve(cloud.gaussians.size() * float_props * 12);
    for (const auto& g : cloud.gaussians) {
      const int n = gather_floats(g, coefs, o.write_normals, v);
      for (int k = 0; k < n; ++k) {
        if (k) text += ' ';
        ply::put_text(text, v[static_cast<std::size_t>(k)]);
      }
      if (o.write_object_id) {
        text += ' ';
        ply::put_text(text, std::int64_t{to_underlying(g.object)});
      }
      if (o.write_gaussian_id) {
        text += ' ';
        ply::put_text(text, std::uint64_t{to_underlying(g.id)});
      }
      if (o.write_support) {
        text += ' ';
        ply::put_text(text, std::uint64_t{g.support});
      }
      text += '\n';
    }
    out.insert(out.end(), text.begin(), text.end());
    return out;
  }

  const bool be = o.format == PlyFormat::BinaryBigEndian;
  out.reserve(out.size() + cloud.gaussians.size() * e.scalar_stride());
  for (const auto& g : cloud.gaussians) {
    const int n = gather_floats(g, coefs, o.write_normals, v);
    for (int k = 0; k < n; ++k) ply::put_float(out, v[static_cast<std::size_t>(k)], be);
    if (o.write_object_id) ply::put_i32(out, to_underlying(g.object), be);
    if (o.write_gaussian_id) {
      if (wide_ids)
        ply::put_u64(out, to_underlying(g.id), be);
      else
        ply::put_u32(out, static_cast<std::uint32_t>(to_underlying(g.id)), be);
    }
    if (o.write_support) ply::put_u32(out, g.support, be);
  }
  return out;
}

Status write_gaussian_ply(const std::filesystem::path& path, const GaussianCloud& cloud,
                          const PlyGaussianWriteOptions& options) {
  auto bytes = encode_gaussian_ply(cloud, options);
  if (!bytes) return Error{path.string() + ": " + bytes.message()};
  return io::write_file_atomic(path, *bytes);
}

}  // namespace gauss
