#include "dump_sent.h"

#include <cctype>
#include <system_error>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/ply_mesh.h"

namespace gauss::host_app {

namespace fs = std::filesystem;

std::string dump_file_stem(std::string_view client_name, std::uint32_t client) {
  if (client_name.empty()) return "client-" + std::to_string(client);
  std::string stem(client_name);
  for (char& c : stem)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return stem;
}

namespace {

// Every surface chunk's mesh, in chunk-id order, as one mesh (vertex colours white where a
// chunk has none).
TriangleMesh surface_mesh(const SceneStore& scene) {
  TriangleMesh all;
  for (const SurfaceChunk& chunk : scene.surface_chunks()) {
    const auto base = static_cast<std::uint32_t>(all.positions.size());
    const TriangleMesh& m = chunk.mesh;
    all.positions.insert(all.positions.end(), m.positions.begin(), m.positions.end());
    if (m.colors.size() == m.positions.size())
      all.colors.insert(all.colors.end(), m.colors.begin(), m.colors.end());
    else
      all.colors.resize(all.positions.size(), glm::u8vec3(255));
    for (std::uint32_t i : m.indices) all.indices.push_back(base + i);
  }
  return all;
}

}  // namespace

Expected<DumpReport> dump_sent(const fs::path& dir, const std::string& stem, const HostSession& session,
                               const SceneStore& scene, const CodecParams& params) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Error{"cannot create " + dir.string() + ": " + ec.message()};
  DumpReport report;
  GaussianCloud cloud;
  cloud.sh_degree = params.sh_degree;
  cloud.gaussians.reserve(session.sent_ids().size());
  for (GaussianId id : session.sent_ids())
    if (std::optional<Gaussian> g = session.sent_record(id)) cloud.gaussians.push_back(*g);
  PlyGaussianWriteOptions options;
  options.write_object_id = true;
  options.write_gaussian_id = true;
  options.write_support = true;  // dequantised, as the client holds it: the records then hash alike
  report.gaussians_path = dir / (stem + ".ply");
  report.gaussians = cloud.gaussians.size();
  if (auto st = write_gaussian_ply(report.gaussians_path, cloud, options); !st) return st.error();
  const TriangleMesh mesh = surface_mesh(scene);
  if (!mesh.positions.empty()) {
    report.mesh_path = dir / (stem + ".mesh.ply");
    report.triangles = mesh.indices.size() / 3;
    if (auto st = write_mesh_ply(report.mesh_path, mesh); !st) return st.error();
  }
  return report;
}

}  // namespace gauss::host_app
