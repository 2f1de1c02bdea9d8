// gauss-demo: the main job on the embedded synthetic scene, end to end in one process.
// A synthetic room evolves over its epochs on the "host" (Gaussians appear where the
// trajectory looked and converge; the TSDF fuses the ground-truth depth into a surface
// mesh), then the renderer draws it: the whole scene, the bounded client set for a
// budget M, and the same budget with a semantic query that reserves most of it for the
// queried objects (highlighted). Each image is written as a PNG and the figures behind
// it are printed.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "gauss/engine/query.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/selector.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "status_line.h"
#include "options.h"

namespace {

using namespace gauss;

int fail(const std::string& what) {
  std::fprintf(stderr, "gauss-demo: %s\n", what.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  demo_app::Options o;
  if (auto rc = demo_app::parse_options(argc, argv, o)) return *rc;
  if (std::error_code ec; !std::filesystem::create_directories(o.out, ec) && ec)
    return fail("cannot create " + o.out.string() + ": " + ec.message());
  const auto t0 = std::chrono::steady_clock::now();

  // ---- Host: the evolving scene and its surface ----
  SyntheticSceneConfig sc;
  sc.variant = o.variant;
  sc.target_gaussians = o.gaussians;
  sc.image_width = 320;  // trajectory frames fused by the TSDF
  sc.image_height = 240;
  sc.focal_px = 240.0;
  auto scene = SyntheticScene::create(sc);
  if (!scene) return fail(scene.message());
  TsdfConfig tc;
  tc.voxel_size = 0.03f;
  auto volume = TsdfVolume::create(tc);
  if (!volume) return fail(volume.message());
  SceneStore store;
  std::size_t chunk_edits = 0;
  apps::StatusLine status;  // the host phase takes seconds
  for (int e = 0; e < scene->epoch_count(); ++e) {
    status.update("host: epoch " + std::to_string(e + 1) + "/" + std::to_string(scene->epoch_count()) + ", " +
                      std::to_string(store.size()) + " Gaussians so far",
                  true);
    if (auto st = scene->produce(store); !st) return fail(st.message());
    for (const Camera& cam : scene->cameras_of_epoch(e))
      if (auto st = volume->integrate(synthetic_rgbd_frame(*scene, cam, store.epoch())); !st) return fail(st.message());
    const auto edits = volume->extract_changed();
    chunk_edits += edits.size();
    if (auto st = store.begin_next_epoch(); !st) return fail(st.message());
    if (auto st = apply_surface_edits(store, edits); !st) return fail(st.message());
    if (auto st = store.commit_epoch(); !st) return fail(st.message());
  }
  status.update("host: extracting the surface mesh", true);
  const TriangleMesh mesh = volume->extract_all();
  status.done({});
  const double host_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("host: %d epochs of synthetic room %d: %zu Gaussians (%zu carriers), %zu objects, surface %zu "
              "triangles in %zu chunk edits (%.1f s)\n",
              scene->epoch_count(), o.variant, store.size(), store.carrier_count(), store.objects().size(),
              mesh.indices.size() / 3, chunk_edits, host_s);

  const Camera view = scene->overview_camera(o.width, o.height);

  // ---- Renderer ----
  vk::ContextCreateInfo ci;
  ci.app_name = "gauss-demo";
  ci.device_override = o.device;
  auto ctx = vk::Context::create(ci);
  if (!ctx) return fail(ctx.message());
  render::SplatRendererCreateInfo ri;
  ri.capacity = std::uint32_t(std::clamp<std::size_t>(store.size(), 1, 0xFFFFFFFFu));
  ri.sh_degree = store.sh_degree();
  ri.max_width = o.width;
  ri.max_height = o.height;
  auto renderer = render::SplatRenderer::create(**ctx, ri);
  if (!renderer) return fail(renderer.message());
  render::SplatRenderer& r = **renderer;
  if (auto st = r.set_mesh(mesh); !st) return fail(st.message());

  // Uploads a set of Gaussians (carriers never drawn) into slots 0..n-1 and renders.
  auto draw = [&](const std::vector<const Gaussian*>& set, const std::string& name) -> int {
    std::vector<Gaussian> slots;
    for (const Gaussian* g : set)
      if (!g->carrier && slots.size() < ri.capacity) slots.push_back(*g);
    if (auto st = r.clear_slots(0, ri.capacity); !st) return fail(st.message());
    if (auto st = r.write_slots(0, slots); !st) return fail(st.message());
    auto stats = r.render(view);
    if (!stats) return fail(stats.message());
    auto image = r.read_image();
    if (!image) return fail(image.message());
    const auto path = o.out / (name + ".png");
    if (auto st = write_png(path, *image); !st) return fail(st.message());
    std::printf("  %-13s %7zu resident, %7u visible, GPU %.1f ms (preprocess %.1f, sorts %.1f, blend %.1f) -> %s\n",
                name.c_str(), slots.size(), stats->visible, stats->gpu.total_ms, stats->gpu.preprocess_ms,
                stats->gpu.depth_sort_ms + stats->gpu.tile_sort_ms, stats->gpu.blend_ms, path.c_str());
    return 0;
  };

  std::printf("render (%ux%u, device: %s):\n", o.width, o.height, (*ctx)->device_name().c_str());
  std::vector<const Gaussian*> all;
  for (const Gaussian& g : store.gaussians()) all.push_back(&g);
  if (int rc = draw(all, "room")) return rc;

  // The bounded client set: M Gaussians chosen for this view, no query.
  Selector selector;
  SelectionRequest req;
  req.budget = std::min(o.budget, store.appearance_count());
  req.client_capacity = ri.capacity;
  auto plain = selector.select(store, ClientPose::from_camera(view), req);
  if (!plain) return fail(plain.message());
  std::vector<const Gaussian*> chosen;
  for (auto idx : plain->indices) chosen.push_back(&store.gaussians()[idx]);
  if (int rc = draw(chosen, "room_budget")) return rc;

  // The same budget with a semantic query: rho*M reserved for the queried objects.
  selector.clear_resident();
  req.query = SemanticQuery::for_class(o.query);
  req.rho = o.rho;
  auto queried = selector.select(store, ClientPose::from_camera(view), req);
  if (!queried) return fail(queried.message());
  chosen.clear();
  for (auto idx : queried->indices) chosen.push_back(&store.gaussians()[idx]);
  const auto ids = queried->query->ids();
  if (auto st = r.set_highlight(ids); !st) return fail(st.message());
  std::printf("query \"%s\" -> %zu objects, %zu Gaussians; budget M = %zu: object share %zu (min(|G_obj|, "
              "floor(rho M)) = %zu), background %zu\n",
              o.query.c_str(), queried->query->objects.size(), queried->object_candidates, queried->budget,
              queried->object_selected, queried->object_budget, queried->background_selected);
  if (int rc = draw(chosen, "room_query")) return rc;

  std::printf("\nimages in %s\n", std::filesystem::absolute(o.out).c_str());
  return 0;
}
