// Fuzz target: the PLY readers (Gaussian scene and mesh) on arbitrary bytes.
// Invariants checked beyond "no crash, no sanitizer report":
// - a rejection always carries a message naming the input;
// - an accepted scene re-encodes (binary LE and ascii) and reads back bit-identical, with no
//   further quaternion normalisation (loading is idempotent);
// - an accepted mesh has colours for every vertex and in-range triangle indices, and
//   round-trips exactly through the writer.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>

#include "fuzz_target.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/ply_mesh.h"

// A named namespace, not an anonymous one: fuzz_replay compiles the targets in unity
// batches, where two files' helpers of the same name would clash.
namespace fuzz_ply {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_ply invariant violated: %s\n", what);
  std::abort();
}

bool same_floats(const void* a, const void* b, std::size_t n) { return std::memcmp(a, b, n) == 0; }

void check_same(const gauss::GaussianCloud& a, const gauss::GaussianCloud& b) {
  if (a.sh_degree != b.sh_degree || a.gaussians.size() != b.gaussians.size()) fail("scene shape changed");
  const int coefs = gauss::sh_rest_count(a.sh_degree);
  for (std::size_t i = 0; i < a.gaussians.size(); ++i) {
    const gauss::Gaussian& x = a.gaussians[i];
    const gauss::Gaussian& y = b.gaussians[i];
    if (!same_floats(&x.position, &y.position, sizeof x.position) ||
        !same_floats(&x.log_scale, &y.log_scale, sizeof x.log_scale) ||
        !same_floats(&x.rotation, &y.rotation, sizeof x.rotation) ||
        !same_floats(&x.opacity_logit, &y.opacity_logit, sizeof x.opacity_logit) ||
        !same_floats(&x.sh_dc, &y.sh_dc, sizeof x.sh_dc) ||
        !same_floats(x.sh_rest.data(), y.sh_rest.data(), sizeof(glm::vec3) * static_cast<std::size_t>(coefs)))
      fail("a float changed in the round trip");
    if (x.id != y.id || x.object != y.object || x.support != y.support) fail("an id/label/support changed");
  }
}

void fuzz_gaussians(std::span<const std::uint8_t> bytes) {
  auto scene = gauss::parse_gaussian_ply(bytes, "fuzz.ply");
  if (!scene.ok()) {
    if (scene.message().rfind("fuzz.ply: ", 0) != 0) fail("rejection without the input's name");
    return;
  }
  for (gauss::PlyFormat f : {gauss::PlyFormat::BinaryLittleEndian, gauss::PlyFormat::Ascii}) {
    gauss::PlyGaussianWriteOptions o;
    o.format = f;
    o.write_object_id = o.write_gaussian_id = o.write_support = true;
    auto encoded = gauss::encode_gaussian_ply(scene->cloud, o);
    if (!encoded.ok()) fail("a loaded scene could not be written");
    auto back = gauss::parse_gaussian_ply(*encoded, "again.ply");
    if (!back.ok()) fail("a written scene could not be read back");
    if (back->report.renormalized_quaternions != 0 || back->report.zero_quaternions != 0)
      fail("quaternions normalised twice");
    check_same(scene->cloud, back->cloud);
  }
}

void fuzz_mesh(std::span<const std::uint8_t> bytes) {
  auto mesh = gauss::parse_mesh_ply(bytes, "fuzz_mesh.ply");
  if (!mesh.ok()) {
    if (mesh.message().rfind("fuzz_mesh.ply: ", 0) != 0) fail("mesh rejection without the input's name");
    return;
  }
  const gauss::TriangleMesh& m = mesh->mesh;
  if (m.colors.size() != m.positions.size() || m.indices.size() % 3 != 0) fail("inconsistent mesh");
  for (std::uint32_t idx : m.indices)
    if (idx >= m.positions.size()) fail("mesh index out of range");
  auto encoded = gauss::encode_mesh_ply(m);
  if (!encoded.ok()) fail("a loaded mesh could not be written");
  auto back = gauss::parse_mesh_ply(*encoded, "again_mesh.ply");
  if (!back.ok()) fail("a written mesh could not be read back");
  if (back->mesh.indices != m.indices || back->mesh.colors != m.colors ||
      back->mesh.positions.size() != m.positions.size() ||
      (!m.positions.empty() &&
       !same_floats(back->mesh.positions.data(), m.positions.data(), m.positions.size() * sizeof(glm::vec3))))
    fail("mesh changed in the round trip");
}

GAUSS_FUZZ_TARGET(ply) {
  const std::span<const std::uint8_t> bytes(data, size);
  fuzz_gaussians(bytes);
  fuzz_mesh(bytes);
  return 0;
}

}  // namespace fuzz_ply
