// Reference rasterizer: preprocess every slot, order the splats front to back once, bin
// them into 16x16 tiles with a stable counting sort (so each tile's list stays in depth
// order), then blend every pixel of every touched tile (splat_math.h), in double.
#include <algorithm>
#include <cmath>
#include <string>
#include <thread>
#include <unordered_set>

#include "gauss/render/reference_rasterizer.h"

namespace gauss::render {
namespace {

Status validate(std::span<const Gaussian> slots, std::span<const std::uint8_t> occupied, int sh_degree,
                const Camera& camera, const ReferenceOptions& o) {
  if (sh_degree < 0 || sh_degree > kMaxShDegree)
    return Error{"reference rasterizer: sh_degree " + std::to_string(sh_degree) + " outside 0..3"};
  if (auto st = validate_camera(camera); !st) return Error{"reference rasterizer: " + st.message()};
  if (!occupied.empty() && occupied.size() != slots.size())
    return Error{"reference rasterizer: " + std::to_string(occupied.size()) + " occupied flags for " +
                 std::to_string(slots.size()) + " slots"};
  if (!o.edit_tints.empty() && o.edit_tints.size() != slots.size())
    return Error{"reference rasterizer: " + std::to_string(o.edit_tints.size()) + " edit tints for " +
                 std::to_string(slots.size()) + " slots"};
  if (o.row_begin >= std::min<std::uint32_t>(o.row_end, camera.height))
    return Error{"reference rasterizer: empty row range [" + std::to_string(o.row_begin) + ", " +
                 std::to_string(o.row_end) + ") for height " + std::to_string(camera.height)};
  const std::size_t pixels = std::size_t(camera.width) * camera.height;
  if (o.mesh) {
    if (!o.mesh->colour || o.mesh->colour->width != camera.width || o.mesh->colour->height != camera.height ||
        o.mesh->colour->pixels.size() != pixels * 4)
      return Error{"reference rasterizer: mesh colour image missing or not " + std::to_string(camera.width) + "x" +
                   std::to_string(camera.height) + " RGBA8"};
    if (o.mesh->view_depth.size() != pixels)
      return Error{"reference rasterizer: mesh depth has " + std::to_string(o.mesh->view_depth.size()) +
                   " samples, expected " + std::to_string(pixels)};
    if (!(std::isfinite(o.mesh->margin) && o.mesh->margin >= 0.0))
      return Error{"reference rasterizer: mesh margin must be finite and >= 0"};
    for (std::size_t i = 0; i < pixels; ++i) {
      const float d = o.mesh->view_depth[i];
      // 0 is refused rather than read as a surface at the eye: it is what "no triangle" looks
      // like in depth images that use 0 for empty pixels (gauss::render_mesh_depth), and
      // reading it as a depth would silently cull every Gaussian.
      if (std::isnan(d) || d <= 0.0f)
        return Error{"reference rasterizer: mesh depth at pixel " + std::to_string(i) + " is " + std::to_string(d) +
                     " (must be > 0, or +inf where no triangle covers the pixel)"};
    }
  }
  return Ok{};
}

struct Context {
  const Camera* camera;
  const ReferenceOptions* options;
  std::vector<ProjectedSplat> splats;  // visible, front to back
  std::vector<std::uint32_t> tile_start;
  std::vector<std::uint32_t> tile_list;  // indices into splats
  std::uint32_t grid_x{0};
  std::uint32_t row_begin{0}, row_end{0};
};

void blend_tile_rows(const Context& ctx, std::uint32_t ty_begin, std::uint32_t ty_end, ReferenceImage& out) {
  const Camera& cam = *ctx.camera;
  const MeshLayer* mesh = ctx.options->mesh;
  for (std::uint32_t ty = ty_begin; ty < ty_end; ++ty) {
    const std::uint32_t y0 = std::max(ty * kTileSize, ctx.row_begin);
    const std::uint32_t y1 = std::min((ty + 1) * kTileSize, ctx.row_end);
    for (std::uint32_t tx = 0; tx < ctx.grid_x; ++tx) {
      const std::uint32_t tile = ty * ctx.grid_x + tx;
      const std::uint32_t first = ctx.tile_start[tile], last = ctx.tile_start[tile + 1];
      const std::uint32_t x1 = std::min((tx + 1) * kTileSize, cam.width);
      for (std::uint32_t i = y0; i < y1; ++i) {
        for (std::uint32_t j = tx * kTileSize; j < x1; ++j) {
          const std::size_t px = std::size_t(i) * cam.width + j;
          const double mesh_depth = mesh ? double(mesh->view_depth[px]) : 0.0;
          glm::dvec3 C(0.0);
          double T = 1.0;
          for (std::uint32_t k = first; k < last; ++k) {
            const ProjectedSplat& s = ctx.splats[ctx.tile_list[k]];
            const double dx = s.u - (double(j) + 0.5);
            const double dy = s.v - (double(i) + 0.5);
            const double power = -0.5 * (s.conic.x * dx * dx + s.conic.z * dy * dy) - s.conic.y * dx * dy;
            if (power > 0.0) continue;
            if (mesh && s.view.z > mesh_depth + mesh->margin) continue;
            const double alpha = std::min(kAlphaMax, s.opacity * std::exp(power));
            if (alpha < kAlphaMin) continue;
            const double test_T = T * (1.0 - alpha);
            if (test_T < kTransmittanceStop) break;
            C += s.colour * (alpha * T);
            T = test_T;
          }
          // out.rgb already holds this pixel's background (filled before the blend).
          const glm::dvec3 bg(out.rgb[px * 3 + 0], out.rgb[px * 3 + 1], out.rgb[px * 3 + 2]);
          const glm::dvec3 final_colour = C + T * bg;
          out.rgb[px * 3 + 0] = final_colour.x;
          out.rgb[px * 3 + 1] = final_colour.y;
          out.rgb[px * 3 + 2] = final_colour.z;
          out.transmittance[px] = T;
        }
      }
    }
  }
}

}  // namespace

Expected<ReferenceImage> render_reference(std::span<const Gaussian> slots, std::span<const std::uint8_t> occupied,
                                          int sh_degree, const Camera& camera, const ReferenceOptions& options) {
  if (auto st = validate(slots, occupied, sh_degree, camera, options); !st) return st.error();

  ReferenceImage out;
  out.width = camera.width;
  out.height = camera.height;
  out.row_begin = options.row_begin;
  out.row_end = std::min(options.row_end, camera.height);
  const std::size_t pixels = std::size_t(camera.width) * camera.height;
  out.rgb.assign(pixels * 3, 0.0);
  out.transmittance.assign(pixels, 1.0);
  ReferenceStats& st = out.stats;
  st.slots = slots.size();

  const std::uint32_t gx = tile_count(camera.width), gy = tile_count(camera.height);
  const std::unordered_set<std::int32_t> highlight = [&] {
    std::unordered_set<std::int32_t> h;
    for (ObjectId id : options.highlight_objects) h.insert(to_underlying(id));
    return h;
  }();

  // Per-tile max mesh depth, for the preprocess cull (never changes the image: every pixel
  // of a culled splat's rectangle would skip it in the blend).
  std::vector<double> tile_max_depth;
  if (options.mesh) {
    tile_max_depth.assign(std::size_t(gx) * gy, 0.0);
    for (std::uint32_t i = 0; i < camera.height; ++i)
      for (std::uint32_t j = 0; j < camera.width; ++j) {
        double& m = tile_max_depth[std::size_t(i / kTileSize) * gx + j / kTileSize];
        m = std::max(m, double(options.mesh->view_depth[std::size_t(i) * camera.width + j]));
      }
  }

  Context ctx;
  ctx.camera = &camera;
  ctx.options = &options;
  ctx.grid_x = gx;
  ctx.row_begin = out.row_begin;
  ctx.row_end = out.row_end;
  for (std::uint32_t slot = 0; slot < slots.size(); ++slot) {
    if (!occupied.empty() && !occupied[slot]) continue;
    ++st.occupied;
    const Gaussian& g = slots[slot];
    const bool hl = !highlight.empty() && highlight.count(to_underlying(g.object)) != 0;
    const EditTintState edit = options.edit_tints.empty() ? EditTintState{} : options.edit_tints[slot];
    ProjectedSplat s = project_splat(g, slot, sh_degree, camera, hl, edit);
    if (s.cull == SplatCull::Visible && options.mesh) {
      double far = 0.0;
      for (std::uint32_t ty = s.tile_min_y; ty < s.tile_max_y; ++ty)
        for (std::uint32_t tx = s.tile_min_x; tx < s.tile_max_x; ++tx)
          far = std::max(far, tile_max_depth[std::size_t(ty) * gx + tx]);
      if (s.view.z > far + options.mesh->margin) s.cull = SplatCull::BehindMesh;
    }
    switch (s.cull) {
      case SplatCull::Visible:
        st.tile_pairs += std::uint64_t(s.tile_max_x - s.tile_min_x) * (s.tile_max_y - s.tile_min_y);
        ctx.splats.push_back(s);
        break;
      case SplatCull::Empty: break;
      case SplatCull::NonFinite: ++st.rejected_nonfinite; break;
      case SplatCull::Removed: ++st.removed_faded; break;
      case SplatCull::Near: ++st.culled_near; break;
      case SplatCull::Degenerate: ++st.culled_degenerate; break;
      case SplatCull::OffScreen: ++st.culled_offscreen; break;
      case SplatCull::BehindMesh: ++st.culled_mesh; break;
    }
  }
  st.visible = ctx.splats.size();

  // Front to back by float32 depth, ties by slot: a total order, so std::sort is deterministic.
  std::sort(ctx.splats.begin(), ctx.splats.end(), [](const ProjectedSplat& a, const ProjectedSplat& b) {
    return a.depth_key != b.depth_key ? a.depth_key < b.depth_key : a.slot < b.slot;
  });

  // Stable counting sort by tile; tile pairs can exceed 2^32 only for absurd inputs, which
  // the tile-list index type would not hold.
  if (st.tile_pairs > std::numeric_limits<std::uint32_t>::max())
    return Error{"reference rasterizer: " + std::to_string(st.tile_pairs) + " tile pairs exceed 2^32"};
  ctx.tile_start.assign(std::size_t(gx) * gy + 1, 0);
  for (const ProjectedSplat& s : ctx.splats)
    for (std::uint32_t ty = s.tile_min_y; ty < s.tile_max_y; ++ty)
      for (std::uint32_t tx = s.tile_min_x; tx < s.tile_max_x; ++tx) ++ctx.tile_start[std::size_t(ty) * gx + tx + 1];
  for (std::size_t t = 1; t < ctx.tile_start.size(); ++t) ctx.tile_start[t] += ctx.tile_start[t - 1];
  ctx.tile_list.resize(st.tile_pairs);
  {
    std::vector<std::uint32_t> cursor(ctx.tile_start.begin(), ctx.tile_start.end() - 1);
    for (std::uint32_t k = 0; k < ctx.splats.size(); ++k) {
      const ProjectedSplat& s = ctx.splats[k];
      for (std::uint32_t ty = s.tile_min_y; ty < s.tile_max_y; ++ty)
        for (std::uint32_t tx = s.tile_min_x; tx < s.tile_max_x; ++tx) ctx.tile_list[cursor[std::size_t(ty) * gx + tx]++] = k;
    }
  }

  // Background everywhere first (rows outside the range keep it; blend_tile_rows reads it
  // back as the pixel's background), then blend tile rows.
  for (std::size_t px = 0; px < pixels; ++px) {
    glm::dvec3 bg = options.clear_colour;
    if (options.mesh) {
      const std::uint8_t* m = &options.mesh->colour->pixels[px * 4];
      bg = glm::dvec3(m[0], m[1], m[2]) / 255.0;
    }
    out.rgb[px * 3 + 0] = bg.x;
    out.rgb[px * 3 + 1] = bg.y;
    out.rgb[px * 3 + 2] = bg.z;
  }
  const std::uint32_t ty_begin = out.row_begin / kTileSize;
  const std::uint32_t ty_end = std::min(gy, (out.row_end + kTileSize - 1) / kTileSize);
  const unsigned threads = std::clamp(options.threads, 1u, std::max(1u, ty_end - ty_begin));
  if (threads == 1) {
    blend_tile_rows(ctx, ty_begin, ty_end, out);
  } else {
    // Interleaved tile rows would balance better, but contiguous bands keep each thread's
    // writes apart; every pixel is written by exactly one thread either way.
    std::vector<std::thread> pool;
    const std::uint32_t rows = ty_end - ty_begin;
    for (unsigned t = 0; t < threads; ++t) {
      const std::uint32_t b = ty_begin + rows * t / threads, e = ty_begin + rows * (t + 1) / threads;
      pool.emplace_back([&ctx, &out, b, e] { blend_tile_rows(ctx, b, e, out); });
    }
    for (auto& th : pool) th.join();
  }

  out.rgba8.width = camera.width;
  out.rgba8.height = camera.height;
  out.rgba8.pixels.resize(pixels * 4);
  for (std::size_t px = 0; px < pixels; ++px) {
    for (int c = 0; c < 3; ++c) out.rgba8.pixels[px * 4 + c] = to_unorm8(out.rgb[px * 3 + c]);
    out.rgba8.pixels[px * 4 + 3] = 255;
  }
  return out;
}

}  // namespace gauss::render
