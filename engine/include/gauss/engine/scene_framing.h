#pragma once
// Where a viewer's first camera goes: the robust bounds of a splat scene and a camera that
// frames them from outside, upright for a given up vector.
//
// Trained scenes carry floaters and background splats far from the subject, so the exact
// bounds are useless for framing: robust_bounds() takes the 2nd and 98th percentiles of the
// centres per axis, weighted by opacity (a transparent floater weighs nothing; a solid
// surface splat weighs ~1). frame_bounds() then looks at the box's centre from outside it,
// from the capture's side (view_side), a little above, at the distance where the whole box
// fits the camera's field of view in both directions.
//
// Bad input never gives a non-finite camera: Gaussians with a non-finite centre are left
// out; a scene with no finite centre gets the unit box around the origin; all-zero (or
// non-finite) opacities count every centre equally; a box of zero size (one Gaussian, or
// all at one point) is grown to kPointBoxHalfExtent around its centre.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/gaussian.h"

namespace gauss {

// The central share of the centres the bounds keep, per axis (2 % cut on each side).
inline constexpr double kRobustLowQuantile = 0.02;
inline constexpr double kRobustHighQuantile = 0.98;
// A box smaller than this (relative to its distance from the origin, or absolute near it)
// is a point: it is grown to +-kPointBoxHalfExtent, so a single Gaussian gets a camera a few
// units away rather than one sitting on it.
inline constexpr double kPointBoxHalfExtent = 1.0;

enum class BoundsWeighting : std::uint8_t {
  Opacity,  // each centre weighs sigmoid(opacity_logit): floaters (faint) do not count
  Count,    // each centre weighs 1 (the evaluation's region, apps/common/central_box.h)
};

struct RobustBounds {
  glm::dvec3 lo{-1.0};
  glm::dvec3 hi{1.0};
  std::size_t finite{0};  // Gaussians with a finite centre (the ones counted)
  // Opacity was asked for and used; false when every weight was 0 or non-finite and the
  // centres were counted equally instead (or when Count was asked for).
  bool opacity_weighted{false};

  glm::dvec3 centre() const { return 0.5 * (lo + hi); }
  glm::dvec3 size() const { return hi - lo; }
};

// Per axis: with Count, the order statistics at floor(n * 2 / 100) and n - 1 - that
// (nth_element, O(n)); with Opacity, the smallest centre whose cumulative weight from below
// exceeds 2 % of the total and the largest whose cumulative weight from above does (a sort,
// O(n log n)). Non-finite centres are skipped; none left: the box [-1, 1]^3 with finite == 0.
RobustBounds robust_bounds(std::span<const Gaussian> gaussians, BoundsWeighting weighting = BoundsWeighting::Opacity);

// The camera's size and focal lengths (pixels) and how close the box may come.
struct FramingLens {
  std::uint32_t width{640}, height{480};
  double fx{457.0}, fy{457.0};
  // The box's nearest corner stays at least this far in front of the camera (the renderer
  // culls Gaussians nearer than its near plane, 0.2).
  double min_depth{0.2};
  // The box's projection spans at most this share of the half-width and half-height, so
  // the percentile box does not touch the image's edges.
  double fill{0.9};
  // The view direction's elevation above the horizontal plane (radians): a little from
  // above, as a person standing in front of the subject looks at it.
  double elevation{0.35};
};

struct Framing {
  glm::dvec3 eye{0.0};
  glm::dvec3 target{0.0, 0.0, 1.0};  // the box's centre
  glm::dvec3 up{0.0, 1.0, 0.0};      // unit; the image's up is as close to it as the view allows
  double distance{1.0};              // |target - eye|
  glm::dvec3 lo{-1.0}, hi{1.0};      // the box framed (after growing a point box)
};

// The horizontal direction (unit) a camera looks along for `up` when nothing says otherwise
// (view_side), and the fly camera's yaw 0: the OpenGL
// habit for +y (looking down -z, +x to the right), the COLMAP one for -y (looking down +z,
// +x to the right), in general -(right x up) with right the most perpendicular of +x / +y.
glm::dvec3 front_direction(const glm::dvec3& up);

// The horizontal direction (unit, perpendicular to `up`) from a box's centre toward where the
// default camera stands: toward `seen_from` (where the capture's cameras stood, from a
// trainer's cameras.json) when that lies outside the box's horizontal footprint
// (|horizontal half extents|); else toward the origin when it does: COLMAP puts its first
// camera at the origin and 3DGS trainers keep COLMAP's frame, so the origin is a place the
// subject was photographed from (the shared fruit_drops label reads mirrored from the other
// side); else (a scene centred on the origin, as web tools write them) -front_direction(up).
glm::dvec3 view_side(const glm::dvec3& centre, const glm::dvec3& half, const glm::dvec3& up,
                     const std::optional<glm::dvec3>& seen_from = std::nullopt);

// The framing of box [lo, hi] for `up` (normalised here; a zero or non-finite up is taken
// as +y) through `lens`, from view_side(..., seen_from). Non-finite box corners give the unit
// box around the origin. The same as frame_preset(..., ViewPreset::Front, ...).
Framing frame_bounds(const glm::dvec3& lo, const glm::dvec3& hi, const glm::dvec3& up, const FramingLens& lens,
                     const std::optional<glm::dvec3>& seen_from = std::nullopt);

// The preset views of a viewer (gauss-view's F / 1, 2, 3), each framing the whole box:
enum class ViewPreset : std::uint8_t {
  Front,  // frame_bounds: from view_side, lens.elevation above the horizontal
  Side,   // a quarter turn about up, from the front view's right: the subject's flank
  Top,    // from above at kTopElevation; the image's up points away from the front side
};

// The top view's elevation (radians, 86 degrees): straight down leaves the image's up
// undefined; below the fly camera's pitch limit (1.55), so a viewer takes it unclamped.
// Every elevation is clamped to +-kTopElevation.
inline constexpr double kTopElevation = 1.5;

// frame_bounds() from the side and elevation `preset` names (the box, up and fallbacks as
// there).
Framing frame_preset(const glm::dvec3& lo, const glm::dvec3& hi, const glm::dvec3& up, const FramingLens& lens,
                     ViewPreset preset, const std::optional<glm::dvec3>& seen_from = std::nullopt);

// The OpenCV camera of a framing through `lens` (principal point at the image centre; near
// and far planes widened where the box needs it: far covers the box from the eye).
Camera framed_camera(const Framing& framing, const FramingLens& lens);

}  // namespace gauss
