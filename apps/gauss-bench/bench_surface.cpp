// gauss-bench surface: TSDF fusion and chunk extraction cost at 1 cm and 2 cm voxels,
// with the mesh accuracy beside each time. Inputs: the embedded synthetic room (exact
// ground truth: accuracy = mean vertex distance to the analytic surface) and, when the
// shared data is present, the real SUN3D study room (accuracy = median |mesh depth -
// input depth| over the input frames).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss/engine/mesh_raster.h"
#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"

namespace {

using namespace gauss::bench;

using namespace gauss;

double mesh_area(const TriangleMesh& m) {
  double a = 0.0;
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const glm::dvec3 p0(m.positions[m.indices[t]]), p1(m.positions[m.indices[t + 1]]), p2(m.positions[m.indices[t + 2]]);
    a += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
  }
  return a;
}

struct SurfaceRow {
  std::string scene;
  float voxel{0};
  std::size_t frames{0};
  double integrate_ms_median{0}, integrate_ms_max{0};
  double extract_ms_per_chunk{0};
  std::size_t chunk_edits{0};
  double bytes_per_m2{0};
  double area_m2{0};
  std::string accuracy_name;
  double accuracy{0};
};

SurfaceRow run(const std::string& name, float voxel, const std::vector<RgbdFrame>& frames, const SyntheticScene* truth) {
  TsdfConfig cfg;
  cfg.voxel_size = voxel;
  cfg.max_blocks = 2'000'000;
  auto vol = TsdfVolume::create(cfg);
  SurfaceRow row;
  row.scene = name;
  row.voxel = voxel;
  row.frames = frames.size();
  std::vector<double> integrate_ms;
  double extract_ms = 0.0;
  for (const auto& f : frames) {
    auto t0 = Clock::now();
    if (auto st = vol->integrate(f); !st) {
      std::fprintf(stderr, "surface bench: %s\n", st.message().c_str());
      std::exit(1);
    }
    integrate_ms.push_back(ms_since(t0));
    t0 = Clock::now();
    row.chunk_edits += vol->extract_changed().size();
    extract_ms += ms_since(t0);
  }
  row.integrate_ms_median = median(integrate_ms);
  row.integrate_ms_max = *std::max_element(integrate_ms.begin(), integrate_ms.end());
  row.extract_ms_per_chunk = row.chunk_edits ? extract_ms / double(row.chunk_edits) : 0.0;
  const TriangleMesh mesh = vol->extract_all();
  row.area_m2 = mesh_area(mesh);
  row.bytes_per_m2 = row.area_m2 > 0 ? double(vol->stats().bytes) / row.area_m2 : 0.0;
  if (truth) {
    double sum = 0.0;
    for (const auto& p : mesh.positions) sum += truth->distance_to_surface(p);
    row.accuracy_name = "mean vertex distance to analytic surface (voxels)";
    row.accuracy = mesh.positions.empty() ? 0.0 : sum / double(mesh.positions.size()) / voxel;
  } else {
    std::vector<double> medians;
    for (const auto& f : frames) {
      const Camera cam = frame_camera(f);
      const auto d = render_mesh_depth(mesh, cam);
      std::vector<double> diffs;
      for (std::size_t k = 0; k < d.size(); ++k)
        if (d[k] > 0 && f.depth[k] > 0) diffs.push_back(std::abs(double(d[k]) - f.depth[k]));
      medians.push_back(median(diffs));
    }
    row.accuracy_name = "median |mesh depth - input depth| (voxels, worst frame)";
    row.accuracy = *std::max_element(medians.begin(), medians.end()) / voxel;
  }
  return row;
}

int bench_surface(const std::string& json_path) {
  std::vector<SurfaceRow> rows;

  SyntheticSceneConfig sc;
  sc.target_gaussians = 10000;
  sc.epochs = 4;
  sc.cameras_per_epoch = 2;
  auto scene = SyntheticScene::create(sc);
  if (!scene) {
    std::fprintf(stderr, "surface bench: %s\n", scene.message().c_str());
    return 1;
  }
  std::vector<RgbdFrame> synthetic;
  for (std::size_t k = 0; k < scene->trajectory().size(); ++k)
    synthetic.push_back(synthetic_rgbd_frame(*scene, scene->trajectory()[k], Epoch(k + 1)));

  std::vector<RgbdFrame> real;
  const char* env = std::getenv("GAUSS_DATA_DIR");
  // $GAUSS_DATA_DIR, else shared/data beside the checkout (as the tests find it).
  const std::filesystem::path data = env && *env ? std::filesystem::path(env)
                                                 : std::filesystem::path(__FILE__).parent_path() / ".." / ".." / ".." /
                                                       "shared" / "data";
  if (auto src = RgbdFolderSource::open(data / "rgbd/sun3d_studyroom")) {
    for (std::size_t i = 0; i < src->frame_count(); ++i)
      if (auto f = src->load(i, Epoch(i + 1))) real.push_back(std::move(*f));
  } else {
    std::printf("(SUN3D study room not found under %s: real-data rows skipped)\n", data.string().c_str());
  }

  for (float voxel : {0.01f, 0.02f}) {
    rows.push_back(run("synthetic room 640x480", voxel, synthetic, &*scene));
    if (!real.empty()) rows.push_back(run("sun3d studyroom 640x480", voxel, real, nullptr));
  }

  std::printf("\n%-26s %6s %6s %12s %12s %14s %8s %12s %10s  %s\n", "scene", "voxel", "frames", "integ ms med",
              "integ ms max", "extract ms/chk", "chunks", "KiB per m2", "area m2", "accuracy");
  nlohmann::json out = nlohmann::json::array();
  for (const SurfaceRow& r : rows) {
    std::printf("%-26s %5.0fcm %6zu %12.1f %12.1f %14.3f %8zu %12.1f %10.2f  %.3f %s\n", r.scene.c_str(),
                double(r.voxel) * 100.0, r.frames, r.integrate_ms_median, r.integrate_ms_max, r.extract_ms_per_chunk,
                r.chunk_edits, r.bytes_per_m2 / 1024.0, r.area_m2, r.accuracy, r.accuracy_name.c_str());
    out.push_back({{"scene", r.scene},
                   {"voxel_m", r.voxel},
                   {"frames", r.frames},
                   {"integrate_ms_median", r.integrate_ms_median},
                   {"integrate_ms_max", r.integrate_ms_max},
                   {"extract_ms_per_changed_chunk", r.extract_ms_per_chunk},
                   {"chunk_edits", r.chunk_edits},
                   {"bytes_per_m2", r.bytes_per_m2},
                   {"surface_area_m2", r.area_m2},
                   {"accuracy", r.accuracy},
                   {"accuracy_metric", r.accuracy_name}});
  }
  if (!write_json(json_path, out, "surface")) return 1;
  return 0;
}

BenchRun bench_surface_setup(CLI::App& cmd) {
  auto json_path = std::make_shared<std::string>("surface_bench.json");
  cmd.add_option("--json", *json_path, "write the results as JSON")->type_name("FILE");
  return [json_path] { return bench_surface(*json_path); };
}

}  // namespace

GAUSS_BENCH("surface", "TSDF integration / extraction time vs voxel size, with mesh accuracy", bench_surface_setup);
