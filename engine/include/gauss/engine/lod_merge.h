#pragma once
// The LoD merge rule: how a parent Gaussian stands in for its children (moment matching, as in
// Kerbl et al. 2024 "A Hierarchical 3D Gaussian Representation", Spark 2 and PlayCanvas
// splat-transform; written from the rule, not from their code).
//
// For each usable child i (see LodLeafStatus) with opacity a_i = sigmoid(opacity_logit),
// scales s_i1 >= s_i2 >= s_i3 (exp(log_scale)), covariance S_i = R_i diag(s_i^2) R_i^T, mean m_i:
//   area      A_i = s_i1 * s_i2           the footprint of its two widest axes: what a view
//                                         sees of a flat surface Gaussian, up to pi
//   weight    w_i = a_i * A_i              how much the child shows
//   mean      m   = sum w_i m_i / W,        W = sum w_i
//   cov       S   = sum w_i (S_i + (m_i - m)(m_i - m)^T) / W   (law of total variance); the record
//             widens the centres' part: W_in + k^2 (S - W_in), W_in = sum w_i S_i / W over the
//             leaves, k = LodMergeConfig::spread (1: the exact match; see there)
//   colour    sh_dc, sh_rest: sum w_i c_i / W, per coefficient
//   opacity   optical depth is conserved: with t_i = -ln(1 - a_i) = softplus(opacity_logit),
//             the parent's t = sum t_i A_i / A, A its own area from S; a = 1 - exp(-t).
// The opacity rule keeps a <= 1 by construction, so the renderer needs no change: it is the
// additive "carry the children's mass" rule (a A = sum a_i A_i) while children are faint or
// spread out (first order in a_i), and where children overlap it composites like the children
// do (two coincident copies of opacity a merge to 1 - (1 - a)^2, as alpha blending gives),
// instead of clamping an additive mass at 1. What it gives up: a parent is one Gaussian, so a
// dense stack's footprint is smoother than the stack; mass stays where it was, shape does not.
// object: the children's common object, else kNoObject; support: the sum (saturating);
// carrier: false.
//
// Moments are exact and associative: a node keeps (W, m, S, sum t_i A_i, DC colour) in double,
// and merging children's moments equals merging all of their leaves at once (up to rounding).
// So every parent is the moment match of all the leaves under it, whatever the tree's shape,
// and a parent's record (its opacity above all) never feeds back into its ancestors. The one
// exception is the SH rest: LodHierarchy keeps an interior node's as its record holds it (in
// floats; a double copy was 360 bytes a node at SH 3), so a parent's is the weighted mean of
// its children's recorded ones, within float rounding per level of the leaves' mean.
//
// Turning moments back into a record: S = V diag(l) V^T by sym_eigen3; log_scale_k = ln(l_k)/2
// with l_k floored at 1e-12 * l_0 (a parent is at most 10^6 times thinner than wide: merged
// covariances are never that flat, and a zero would make ln(0)); rotation = V as a unit
// quaternion (w, x, y, z); the opacity logit ln(e^t - 1) is clamped to [-60, 60] (sigmoid is 0
// or 1 to float beyond that: clamping only keeps it finite).
#include <cstdint>
#include <span>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {

struct SymEigen3;

// Why a Gaussian may or may not enter a merge.
enum class LodLeafStatus : std::uint8_t {
  Usable,
  NonFinite,   // a NaN/Inf in position, log_scale, rotation, opacity or colour, or a zero rotation
  ZeroWeight,  // opacity * area is 0 in double (logit < -745 or scales < ~1e-160): no influence
  TooLarge,    // widest scale above LodMergeConfig::max_scale (1e30 blobs would own every parent)
};
const char* to_string(LodLeafStatus s);

struct LodMergeConfig {
  // Metres. A Gaussian wider than this is left out of every merge: its weight (area ~ s^2)
  // would swamp any parent (and a covariance of 1e60 is no use as a coarse stand-in). The
  // eligibility filter normally drops such blobs (> 2 m) before they get here.
  double max_scale{1e4};
  // How much a record widens the layout of its leaves' centres (the covariance of the centres,
  // cov - within), leaving the leaves' own shapes as they are. The exact moment match (1)
  // covers too little: leaves spread evenly over an extent L have a centre variance of
  // L^2 / 12, so the record's 1-sigma ellipse reaches only 0.58 of the way to the layout's
  // edge, its opacity there is e^-1.5 of its peak, and a cut of such records shows a grid of
  // dots with dark seams. sqrt(3) puts the 1-sigma ellipse at that edge. Measured on
  // gauss-eval's rooms 0 and 2 at M = N/8 (2.5k of 20k, 3 cameras each): coverage 85-91 % at 1,
  // 100 % at 1.5 and above; GT-HS 13.3-17.2 dB at 1, 18.2-23.1 at sqrt(3), within 0.6 dB of
  // that at 2 and 2.5. Widening keeps the optical mass (opacity follows the wider area), so
  // opacity stays <= 1. At least 1.
  double spread{1.7320508075688772};
};

// Accumulated moments of a set of Gaussians, in double (see the header comment). SH rest
// moments live beside, sh_rest_count(degree) triples per set (so SH0 scenes carry none).
struct LodMoments {
  double weight{0.0};            // W = sum a_i A_i  (> 0 for every usable set)
  glm::dvec3 mean{0.0};
  double cov[6]{};               // about mean: xx, xy, xz, yy, yz, zz
  double within[6]{};            // the leaves' own covariances, weighted mean (cov - within: their centres' spread)
  double optical_mass{0.0};      // sum t_i A_i
  glm::dvec3 sh_dc{0.0};         // weighted mean
  std::uint64_t support{0};      // sum (saturated to uint32 in the record)
  ObjectId object{kNoObject};    // common object; kNoObject when mixed or unlabelled
};

// Moments of one Gaussian; `rest_out` receives sh_rest_count(sh_degree) triples. Anything but
// Usable leaves `out` and `rest_out` unspecified.
LodLeafStatus leaf_moments(const Gaussian& g, int sh_degree, const LodMergeConfig& config, LodMoments& out,
                           std::span<glm::dvec3> rest_out);

// Combines children's moments (all with weight > 0; at least one) into `out`. `children_rest`
// holds rest_count triples per child, in child order; `rest_out` receives rest_count triples.
void combine_moments(std::span<const LodMoments> children, std::span<const glm::dvec3> children_rest,
                     int rest_count, LodMoments& out, std::span<glm::dvec3> rest_out);

// The record standing for `m` (id 0: the caller names it). Every field is finite for any
// moments combine_moments or leaf_moments produced.
// `spread` widens the layout of the leaves' centres in the record (LodMergeConfig::spread; 1 is
// the exact moment match).
Gaussian moments_to_gaussian(const LodMoments& m, std::span<const glm::dvec3> rest, int rest_count,
                             double spread = 1.0);
// The same in two steps, so that a caller with many records to make can decompose their
// covariances side by side (sym_eigen3_lanes): the covariance the record stands for (spread
// applied), then, from its eigen decomposition, the geometry fields (position, scale, rotation,
// opacity). moments_to_gaussian is these and moments_appearance, bit for bit.
glm::dmat3 moments_covariance(const LodMoments& m, double spread);
void moments_geometry(const LodMoments& m, const SymEigen3& eigen, Gaussian& g);
// Its appearance fields alone (colour, SH rest, object, support) into `g`. Its geometry
// (position, scale, rotation, opacity) is a function of mean, cov, within and optical_mass
// only: a remerge that leaves those bit for bit as they were keeps the old geometry and
// writes these (a recolouring changes no eigen decomposition).
void moments_appearance(const LodMoments& m, std::span<const glm::dvec3> rest, int rest_count, Gaussian& g);
// Whether two moments give the same geometry: mean, cov, within and optical_mass bit for bit.
bool same_geometry(const LodMoments& a, const LodMoments& b);

// Covariance of a Gaussian as a symmetric matrix in double (R diag(exp(2 log_scale)) R^T, the
// rotation normalised): what leaf_moments uses, exposed for tests and callers that measure.
glm::dmat3 gaussian_covariance(const Gaussian& g);

// The whole rule on a list: the merge of `children` under sh_degree. Fails, naming the count,
// when none of them is usable (the parent would stand for nothing: it is not emitted).
Expected<Gaussian> merge_gaussians(std::span<const Gaussian> children, int sh_degree,
                                   const LodMergeConfig& config = {});

}  // namespace gauss
