// gauss-render: renders one view (or a stereo pair) of a 3DGS scene to PNG, on the GPU
// (SplatRenderer) or with the CPU reference rasterizer (--reference).
//
// Options in options.cpp (--help lists them).
//
// Exit status: 0 written; 1 a file could not be read or written, no usable Vulkan device,
// or a render error (the message says which); 2 bad arguments (CLI11's message printed).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <fstream>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/splat_file.h"
#include "gauss/engine/ply_mesh.h"
#include "gauss/render/image_metrics.h"
#include "gauss/render/mesh_pass.h"
#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "status_line.h"
#include "options.h"

namespace {

using namespace gauss;
namespace fs = std::filesystem;

using Args = render_app::Options;

// Writes the image, then (with --compare) prints its difference to another PNG.
int write_and_compare(const Args& a, const fs::path& path, const ImageRGBA8& image) {
  if (auto st = write_png(path, image); !st) {
    std::fprintf(stderr, "gauss-render: %s\n", st.message().c_str());
    return 1;
  }
  std::printf("wrote %s\n", path.c_str());
  if (a.compare.empty()) return 0;
  auto other = read_png_rgba8(a.compare);
  if (!other) {
    std::fprintf(stderr, "gauss-render: %s\n", other.message().c_str());
    return 1;
  }
  auto d = render::compare_images(image, *other);
  if (!d) {
    std::fprintf(stderr, "gauss-render: %s\n", d.message().c_str());
    return 1;
  }
  std::printf("vs %s: PSNR %.2f dB, max abs error %d/255, %llu of %llu pixels differ\n", a.compare.c_str(),
              d->psnr_db, d->max_abs_error, (unsigned long long)d->pixels_differing, (unsigned long long)d->pixels);
  return 0;
}

fs::path eye_path(const fs::path& out, const char* eye) {
  fs::path p = out;
  p.replace_filename(out.stem().string() + "_" + eye + out.extension().string());
  return p;
}

void print_timings(const char* view, int frame, const render::SplatFrameStats& s) {
  const auto& g = s.gpu;
  std::printf("%s frame %d: gpu ms mesh %.3f preprocess %.3f compact %.3f depth_sort %.3f emit %.3f "
              "tile_sort %.3f ranges %.3f blend %.3f total %.3f | visible %u pairs %u%s\n",
              view, frame, g.mesh_ms, g.preprocess_ms, g.compact_ms, g.depth_sort_ms, g.emit_ms, g.tile_sort_ms,
              g.ranges_ms, g.blend_ms, g.total_ms, s.visible, s.pairs, s.pair_overflow ? " (PAIR OVERFLOW)" : "");
}

Expected<std::unique_ptr<vk::Context>> make_context(const Args& a) {
  auto ctx = vk::Context::create({.app_name = "gauss-render", .device_override = a.device});
  if (!ctx) return Error{"no usable Vulkan device: " + ctx.message()};
  return ctx;
}

int run_gpu(const Args& a, const SplatScene& scene, const TriangleMesh* mesh, const Camera& cam) {
  auto ctx = make_context(a);
  if (!ctx) {
    std::fprintf(stderr, "gauss-render: %s\n", ctx.message().c_str());
    return 1;
  }
  const auto& gs = scene.cloud.gaussians;
  render::SplatRendererCreateInfo ci;
  ci.capacity = static_cast<std::uint32_t>(std::max<std::size_t>(1, gs.size()));
  ci.sh_degree = scene.cloud.sh_degree;
  ci.max_width = cam.width;
  ci.max_height = cam.height;
  if (gs.size() > 0xFFFFFFFFu) {
    std::fprintf(stderr, "gauss-render: %zu Gaussians, more than 2^32 - 1 slots\n", gs.size());
    return 1;
  }
  auto renderer = render::SplatRenderer::create(**ctx, ci);
  if (!renderer) {
    std::fprintf(stderr, "gauss-render: %s\n", renderer.message().c_str());
    return 1;
  }
  auto& r = **renderer;
  if (auto st = r.write_slots(0, gs); !st) {
    std::fprintf(stderr, "gauss-render: %s\n", st.message().c_str());
    return 1;
  }
  if (mesh) {
    if (auto st = r.set_mesh(*mesh); !st) {
      std::fprintf(stderr, "gauss-render: mesh %s: %s\n", a.mesh.c_str(), st.message().c_str());
      return 1;
    }
  }
  std::printf("device: %s | %zu Gaussians (SH degree %d), %ux%u%s\n", (*ctx)->device_name().c_str(), gs.size(),
              scene.cloud.sh_degree, cam.width, cam.height, mesh ? ", with mesh" : "");
  render::SplatRenderOptions opt;
  opt.clear_colour = glm::vec3(a.clear);
  const Camera left = render::stereo_eye_camera(cam, a.ipd, render::Eye::Left);
  const Camera right = render::stereo_eye_camera(cam, a.ipd, render::Eye::Right);
  for (int f = 0; f < a.frames; ++f) {
    if (a.stereo) {
      auto st = r.render_stereo(left, right, opt);
      if (!st) {
        std::fprintf(stderr, "gauss-render: %s\n", st.message().c_str());
        return 1;
      }
      print_timings("left ", f, (*st)[0]);
      print_timings("right", f, (*st)[1]);
    } else {
      auto st = r.render(cam, opt);
      if (!st) {
        std::fprintf(stderr, "gauss-render: %s\n", st.message().c_str());
        return 1;
      }
      print_timings("view", f, *st);
    }
  }
  const int views = a.stereo ? 2 : 1;
  for (int v = 0; v < views; ++v) {
    const fs::path path = a.stereo ? eye_path(a.out, v == 0 ? "left" : "right") : a.out;
    auto image = r.read_image(std::uint32_t(v));
    if (!image) {
      std::fprintf(stderr, "gauss-render: %s\n", image.message().c_str());
      return 1;
    }
    if (int rc = write_and_compare(a, path, *image); rc != 0) return rc;
  }
  return 0;
}

// The mesh layer for the CPU path: the GPU mesh pass's colour and view depth, read back.
struct MeshImages {
  ImageRGBA8 colour;
  std::vector<float> depth;
};

Expected<MeshImages> rasterize_mesh(vk::Context& ctx, const TriangleMesh& mesh, const Camera& cam,
                                    const glm::dvec3& clear) {
  auto pass = render::MeshPass::create(ctx);
  if (!pass) return pass.error();
  if (auto st = pass->set_mesh(ctx, mesh); !st) return st.error();
  auto target = vk::OffscreenTarget::create(ctx, cam.width, cam.height, "gauss-render mesh");
  if (!target) return target.error();
  if (auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) { pass->record(cmd, *target, cam, glm::vec3(clear)); });
      !st)
    return st.error();
  auto colour = target->read_color(ctx);
  if (!colour) return colour.error();
  auto depth = target->read_depth(ctx);
  if (!depth) return depth.error();
  for (float& d : *depth) d = render::MeshPass::stored_to_view_depth(d);
  return MeshImages{std::move(*colour), std::move(*depth)};
}

int run_reference(const Args& a, const SplatScene& scene, const TriangleMesh* mesh, const Camera& cam) {
  const auto& gs = scene.cloud.gaussians;
  std::unique_ptr<vk::Context> ctx;
  if (mesh) {
    auto c = make_context(a);
    if (!c) {
      std::fprintf(stderr, "gauss-render: --reference with --mesh rasterizes the mesh on the GPU: %s\n",
                   c.message().c_str());
      return 1;
    }
    ctx = std::move(*c);
  }
  const int views = a.stereo ? 2 : 1;
  for (int v = 0; v < views; ++v) {
    const Camera view_cam =
        a.stereo ? render::stereo_eye_camera(cam, a.ipd, v == 0 ? render::Eye::Left : render::Eye::Right) : cam;
    MeshImages mesh_images;
    render::MeshLayer layer;
    render::ReferenceOptions opt;
    opt.clear_colour = a.clear;
    opt.threads = a.threads;
    if (mesh) {
      auto m = rasterize_mesh(*ctx, *mesh, view_cam, a.clear);
      if (!m) {
        std::fprintf(stderr, "gauss-render: mesh pass: %s\n", m.message().c_str());
        return 1;
      }
      mesh_images = std::move(*m);
      layer.colour = &mesh_images.colour;
      layer.view_depth = mesh_images.depth;
      opt.mesh = &layer;
    }
    const auto t0 = std::chrono::steady_clock::now();
    // Seconds to minutes for big scenes, with no progress of its own: count up meanwhile.
    auto im = apps::with_elapsed_status(
        std::string("gauss-render: reference ") + (a.stereo ? (v == 0 ? "left" : "right") : "view"),
        [&] { return render::render_reference(gs, {}, scene.cloud.sh_degree, view_cam, opt); });
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (!im) {
      std::fprintf(stderr, "gauss-render: %s\n", im.message().c_str());
      return 1;
    }
    const auto& s = im->stats;
    std::printf("reference %s: cpu ms %.1f (%u threads) | visible %llu pairs %llu, culled near %llu offscreen %llu "
                "degenerate %llu mesh %llu, non-finite %llu\n",
                a.stereo ? (v == 0 ? "left " : "right") : "view", ms, a.threads, (unsigned long long)s.visible,
                (unsigned long long)s.tile_pairs, (unsigned long long)s.culled_near,
                (unsigned long long)s.culled_offscreen, (unsigned long long)s.culled_degenerate,
                (unsigned long long)s.culled_mesh, (unsigned long long)s.rejected_nonfinite);
    const fs::path path = a.stereo ? eye_path(a.out, v == 0 ? "left" : "right") : a.out;
    if (int rc = write_and_compare(a, path, im->rgba8); rc != 0) return rc;
  }
  return 0;
}

// Reorders `cloud` to the gaussian_id order listed in the JSON array at `path`. Errors:
// unreadable JSON, an id that is not in the scene or listed twice, a count that differs.
Status apply_slot_order(const std::filesystem::path& path, GaussianCloud& cloud) {
  std::ifstream in(path);
  nlohmann::json ids;
  try {
    in >> ids;
  } catch (const nlohmann::json::exception& e) {
    return Error{path.string() + ": " + e.what()};
  }
  if (!ids.is_array()) return Error{path.string() + ": expected a JSON array of gaussian ids"};
  if (ids.size() != cloud.gaussians.size())
    return Error{path.string() + ": " + std::to_string(ids.size()) + " ids for a scene of " +
                 std::to_string(cloud.gaussians.size()) + " Gaussians"};
  std::unordered_map<std::uint64_t, std::size_t> where;
  for (std::size_t i = 0; i < cloud.gaussians.size(); ++i) where[to_underlying(cloud.gaussians[i].id)] = i;
  std::vector<Gaussian> ordered;
  ordered.reserve(ids.size());
  std::vector<std::uint8_t> used(cloud.gaussians.size(), 0);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (!ids[k].is_number_unsigned()) return Error{path.string() + ": entry " + std::to_string(k) + " is not an id"};
    auto it = where.find(ids[k].get<std::uint64_t>());
    if (it == where.end() || used[it->second])
      return Error{path.string() + ": id " + ids[k].dump() + " (entry " + std::to_string(k) + ") is " +
                   (it == where.end() ? "not in the scene" : "listed twice")};
    used[it->second] = 1;
    ordered.push_back(cloud.gaussians[it->second]);
  }
  cloud.gaussians = std::move(ordered);
  return Ok{};
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (auto rc = render_app::parse_options(argc, argv, args)) return *rc;
  auto scene = apps::with_elapsed_status("gauss-render: reading " + args.scene.string(),
                                        [&] { return read_splat_file(args.scene); });
  if (!scene) {
    std::fprintf(stderr, "gauss-render: %s\n", scene.message().c_str());
    return 1;
  }
  for (const std::string& note : splat_load_notes(scene->report))
    std::fprintf(stderr, "gauss-render: %s: %s\n", args.scene.string().c_str(), note.c_str());
  if (!args.order.empty())
    if (auto st = apply_slot_order(args.order, scene->cloud); !st) {
      std::fprintf(stderr, "gauss-render: %s\n", st.message().c_str());
      return 1;
    }
  auto camera = read_camera_json(args.camera);
  if (!camera) {
    std::fprintf(stderr, "gauss-render: %s\n", camera.message().c_str());
    return 1;
  }
  if (auto st = render::validate_camera(*camera); !st) {
    std::fprintf(stderr, "gauss-render: %s: %s\n", args.camera.c_str(), st.message().c_str());
    return 1;
  }
  std::optional<PlyMeshScene> mesh;
  if (!args.mesh.empty()) {
    auto m = read_mesh_ply(args.mesh);
    if (!m) {
      std::fprintf(stderr, "gauss-render: %s\n", m.message().c_str());
      return 1;
    }
    mesh = std::move(*m);
  }
  const TriangleMesh* mesh_ptr = mesh ? &mesh->mesh : nullptr;
  return args.reference ? run_reference(args, *scene, mesh_ptr, *camera) : run_gpu(args, *scene, mesh_ptr, *camera);
}
