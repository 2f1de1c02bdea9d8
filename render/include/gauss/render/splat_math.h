#pragma once
// THE splat math, defined once. The CPU reference rasterizer (double precision, the test
// oracle) and the Vulkan compute pipeline (float) both follow these statements; a change
// here is a change to both. GLSL cannot include this file: shaders/shared/splat_layout.h
// mirrors the constants that shaders need, and its C++ side static_asserts equality with
// the values below so they cannot drift.
//
// Origin: graphdeco-inria diff-gaussian-rasterization forward.cu (preprocessCUDA,
// computeCov2D, computeColorFromSH, getRect, renderCUDA), restated for the OpenCV camera
// of gauss/engine/camera.h. Where ours differs from that code, it says so.
//
// ---- Per Gaussian (preprocess), slot s -------------------------------------------------
//  0. Empty slot -> skip. A slot with any non-finite field (position, log_scale, rotation,
//     opacity_logit, sh_dc, sh_rest up to the scene degree) is rejected and counted; it is
//     never drawn. The rotation is already unit (normalize_quaternion at load: zero -> identity).
//  1. View space: t = W p + w, with W the upper-left 3x3 and w the translation of
//     camera.world_to_camera (assumed rigid). Camera centre c = -W^T w.
//  2. Near cull: skip when t.z <= kNearCull (0.2 m, fixed; Camera::near_plane is not read).
//  3. Sigma = R S S^T R^T, R from q = (w,x,y,z) (the standard unit-quaternion matrix),
//     S = diag(exp(log_scale)).
//  4. EWA Jacobian with the frustum clamp: lim_x = kFrustumClamp * width / (2 fx),
//     lim_y = kFrustumClamp * height / (2 fy); tx = clamp(t.x/t.z, -lim_x, lim_x) * t.z,
//     ty likewise; J = [[fx/t.z, 0, -fx tx/t.z^2], [0, fy/t.z, -fy ty/t.z^2]] (2x3).
//     cov2D = (J W) Sigma (J W)^T = [[a, b], [b, c]]; a += kDilation; c += kDilation.
//  5. det = a c - b^2; det == 0 -> skip. conic = (c/det, -b/det, a/det) =: (A, B, C).
//  6. mid = (a + c)/2; root = sqrt(max(kLambdaFloor, mid^2 - det)); l1 = mid + root,
//     l2 = mid - root; radius = ceil(3 sqrt(max(l1, l2))) (an integer number of pixels).
//  7. Centre in pixels, from the UNCLAMPED t: u = fx t.x/t.z + cx, v = fy t.y/t.z + cy.
//  8. Tile rectangle (getRect), grid = (ceil(width/16), ceil(height/16)):
//       x_min = min(grid.x, max(0, trunc((u - radius)/16)))
//       x_max = min(grid.x, max(0, trunc((u + radius + 15)/16)))      (exclusive)
//     and the same in y with v. The clamp is applied in floating point before the integer
//     conversion (the reference converts first, which is undefined for huge u; equal
//     otherwise). radius == 0 or an empty rectangle -> skip. Every pixel of every touched
//     tile is evaluated.
//  9. Colour: dir = normalize(p - c); SH up to the scene degree with kShC0..kShC3 exactly as
//     computeColorFromSH (sh[0] = sh_dc, sh[k] = sh_rest[k-1]); colour = SH + 0.5, then
//     max(colour, 0) per channel (no upper clamp: the final output clamp handles > 1).
// 10. opacity = 1 / (1 + exp(-opacity_logit)).
// 11. Tints (section below), then the mesh preprocess cull (section below).
//
// ---- Order ------------------------------------------------------------------------------
//  Front to back by depth_key = float32(t.z) (t.z rounded to nearest float), ties by
//  ascending slot index. The key is float so that the CPU and GPU paths tie in the same
//  places: two Gaussians whose depths are equal in float order by slot on both paths.
//
// ---- Per pixel (blend) ------------------------------------------------------------------
//  Pixel (row i, column j) samples the image plane at (j + 0.5, i + 0.5) (OpenCV; the
//  reference's ndc2Pix instead centres pixels on integers). For each Gaussian of the pixel's
//  tile, in order:
//     dx = u - (j + 0.5); dy = v - (i + 0.5)
//     power = -0.5 (A dx^2 + C dy^2) - B dx dy;      power > 0 -> next Gaussian
//     mesh: t.z > mesh_depth(i, j) + margin          -> next Gaussian   (mesh only)
//     alpha = min(kAlphaMax, opacity exp(power));    alpha < kAlphaMin -> next Gaussian
//     test_T = T (1 - alpha);  test_T < kTransmittanceStop -> pixel done, this one NOT blended
//     C += colour alpha T;  T = test_T
//  starting from C = 0, T = 1. Final: C + T background, background = mesh colour at the
//  pixel when a mesh layer is present, else the clear colour (default black).
//  Output RGBA8 per channel: floor(clamp(x, 0, 1) * 255 + 0.5), alpha 255 (to_unorm8).
//
// ---- Mesh -------------------------------------------------------------------------------
//  The mesh pass gives, per pixel, a colour (RGBA8, already the clear colour where no
//  triangle covers the pixel; read as byte / 255) and a view depth (metres, positive z in
//  the camera frame; +infinity where no triangle covers the pixel). The per-fragment test
//  is in the blend above. Preprocess additionally culls a Gaussian with
//  t.z > max(mesh depth over every pixel of its tile rectangle) + margin: every fragment
//  would be skipped anyway, so this never changes the image (a per-tile max-depth buffer
//  gives that maximum). margin defaults to kDefaultMeshMargin.
//
// ---- Tints (per Gaussian colour/opacity, applied after step 10) -------------------------
//  Highlight (the Gaussian's object id is in the highlight set):
//     colour = colour + kHighlightStrength (kHighlightColour - colour)
//  Edit visualisation (per slot: kind, age = display frames since the edit, 0 on its frame):
//     Added / Replaced, age < kEditTintFrames:
//        s = kEditTintStrength (kEditTintFrames - age) / kEditTintFrames
//        colour = colour + s (kAddedColour or kReplacedColour - colour)
//     Removed, age < kRemovedFadeFrames:
//        colour = colour + kEditTintStrength (kRemovedColour - colour)
//        opacity = opacity (kRemovedFadeFrames - age) / kRemovedFadeFrames
//     Removed, age >= kRemovedFadeFrames: not drawn (skipped like an empty slot).
//     Otherwise (None, or an expired Added/Replaced tint): unchanged.
//  Highlight is applied first, then the edit tint. With neither active the tint work is
//  skipped entirely (the GPU specialises it away); the result is then bit-identical.
//
// ---- Stereo -----------------------------------------------------------------------------
//  Two views per frame: eye camera = centre camera moved by -IPD/2 (left) / +IPD/2 (right)
//  along its own x axis, same intrinsics (stereo_eye_camera below).
#include <array>
#include <cmath>
#include <cstdint>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/gaussian.h"  // kShC0

namespace gauss::render {

// Screen tiles are kTileSize x kTileSize pixels (the reference's BLOCK_X/BLOCK_Y).
inline constexpr int kTileSize = 16;
// Low-pass dilation added to both diagonal entries of the 2D covariance (pixels^2).
inline constexpr double kDilation = 0.3;
// tx/tz and ty/tz are clamped to +-kFrustumClamp * tan(half field of view) inside J only.
inline constexpr double kFrustumClamp = 1.3;
// Gaussians with view depth t.z <= kNearCull (metres) are culled.
inline constexpr double kNearCull = 0.2;
// Floor under mid^2 - det in the eigenvalue computation (the reference's 0.1).
inline constexpr double kLambdaFloor = 0.1;
// Extent of the footprint in standard deviations (radius = ceil(kSigmaExtent sqrt(lambda))).
inline constexpr double kSigmaExtent = 3.0;
// Fragments with alpha below kAlphaMin add nothing and are skipped.
inline constexpr double kAlphaMin = 1.0 / 255.0;
// Alpha is capped so that no single Gaussian makes a pixel fully opaque.
inline constexpr double kAlphaMax = 0.99;
// A pixel stops when blending the next fragment would take T below this.
inline constexpr double kTransmittanceStop = 1e-4;
// Default mesh-occlusion margin (metres): about one TSDF voxel, so Gaussians lying on the
// surface are never cut by their own coarse proxy.
inline constexpr double kDefaultMeshMargin = 0.02;

// Real SH basis constants (computeColorFromSH), sh[0] .. sh[15] (kShC0: gaussian.h).
inline constexpr double kShC1 = 0.4886025119029199;
inline constexpr std::array<double, 5> kShC2 = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                                                -1.0925484305920792, 0.5462742152960396};
inline constexpr std::array<double, 7> kShC3 = {-0.5900435899266435, 2.890611442640554,  -0.4570457994644658,
                                                0.3731763325901154,  -0.4570457994644658, 1.445305721320277,
                                                -0.5900435899266435};

// Highlight tint: how far a highlighted Gaussian's colour moves toward kHighlightColour.
inline constexpr double kHighlightStrength = 0.5;
inline constexpr std::array<double, 3> kHighlightColour = {1.0, 0.8, 0.0};
// Edit-visualisation tint strength on the frame of the edit, and its colours.
inline constexpr double kEditTintStrength = 0.6;
inline constexpr std::array<double, 3> kAddedColour = {0.0, 1.0, 0.0};
inline constexpr std::array<double, 3> kReplacedColour = {0.0, 0.0, 1.0};
inline constexpr std::array<double, 3> kRemovedColour = {1.0, 0.0, 0.0};
// Frames over which an added/replaced tint fades out (a few frames at 72-120 Hz).
inline constexpr std::uint32_t kEditTintFrames = 8;
// Frames a removed Gaussian stays drawn (red, fading opacity) before it disappears.
inline constexpr std::uint32_t kRemovedFadeFrames = 8;

enum class EditTintKind : std::uint8_t { None = 0, Added = 1, Replaced = 2, Removed = 3 };

// Per-slot edit-visualisation state; age counts display frames since the edit (0 on its frame).
struct EditTintState {
  EditTintKind kind{EditTintKind::None};
  std::uint32_t age{0};
};

// Number of 16x16 tiles covering `pixels` pixels.
constexpr std::uint32_t tile_count(std::uint32_t pixels) {
  return (pixels + kTileSize - 1) / kTileSize;
}

// RGBA8 conversion of one channel, the only rounding in the pipeline.
inline std::uint8_t to_unorm8(double x) {
  if (!(x > 0.0)) return 0;  // also maps NaN to 0 (cannot happen for valid input; never UB)
  if (x >= 1.0) return 255;
  return static_cast<std::uint8_t>(std::floor(x * 255.0 + 0.5));
}

inline double sigmoid(double logit) { return 1.0 / (1.0 + std::exp(-logit)); }

// Tint of one Gaussian; returns false when the Gaussian is not drawn at all (removed and
// faded out). colour and opacity are modified in place.
inline bool apply_tints(bool highlighted, EditTintState edit, glm::dvec3& colour, double& opacity) {
  auto mix_toward = [&colour](const std::array<double, 3>& target, double s) {
    colour = colour + s * (glm::dvec3(target[0], target[1], target[2]) - colour);
  };
  if (highlighted) mix_toward(kHighlightColour, kHighlightStrength);
  switch (edit.kind) {
    case EditTintKind::None:
      break;
    case EditTintKind::Added:
    case EditTintKind::Replaced:
      if (edit.age < kEditTintFrames) {
        const double s = kEditTintStrength * double(kEditTintFrames - edit.age) / double(kEditTintFrames);
        mix_toward(edit.kind == EditTintKind::Added ? kAddedColour : kReplacedColour, s);
      }
      break;
    case EditTintKind::Removed:
      if (edit.age >= kRemovedFadeFrames) return false;
      mix_toward(kRemovedColour, kEditTintStrength);
      opacity *= double(kRemovedFadeFrames - edit.age) / double(kRemovedFadeFrames);
      break;
  }
  return true;
}

enum class Eye : std::uint8_t { Left = 0, Right = 1 };

// Eye camera for stereo: the centre camera moved by -ipd/2 (left) or +ipd/2 (right) along
// its own x axis. In view space every point shifts by the opposite amount, so only the
// x translation of world_to_camera changes.
inline Camera stereo_eye_camera(const Camera& centre, double ipd, Eye eye) {
  Camera c = centre;
  const double shift = (eye == Eye::Left ? -0.5 : 0.5) * ipd;
  c.world_to_camera[3][0] -= shift;
  return c;
}

}  // namespace gauss::render
