#pragma once
// Eigen-decomposition of a symmetric 3x3 matrix (GLM has none): the LoD merge turns a merged
// covariance back into scales and a rotation with it.
//
// Cyclic Jacobi in double precision. Jacobi, not the closed-form cubic: the closed form loses
// every digit of the small eigenvalues of a flat covariance (3DGS surface Gaussians are
// 100-10,000 times thinner than wide), and its eigenvectors fall apart for repeated
// eigenvalues; Jacobi's rotations are orthogonal by construction, so the vectors stay
// orthonormal whatever the spectrum, and each small eigenvalue keeps its relative accuracy.
#include <span>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace gauss {

struct SymEigen3 {
  // Eigenvalues in descending order: values[0] >= values[1] >= values[2].
  glm::dvec3 values{0.0};
  // vectors[k] (column k) is the unit eigenvector of values[k]; the columns form a proper
  // rotation (determinant +1), so the matrix converts straight to a quaternion.
  glm::dmat3 vectors{1.0};
  int sweeps{0};  // Jacobi sweeps used (<= kSymEigen3MaxSweeps)
};

// A sweep rotates each of the 3 off-diagonal pairs once; double precision converges in 5-6
// sweeps (quadratic convergence), so 32 is a bound that is never reached on finite input.
inline constexpr int kSymEigen3MaxSweeps = 32;

// Decomposes `a` = V diag(values) V^T. Only the lower triangle (a[c][r], r >= c; GLM is
// column-major) is read, so a slightly asymmetric input is treated as its lower triangle
// mirrored. Input must be finite: with a NaN or Inf entry the result is unspecified (the
// caller checks; the LoD merge never passes one).
SymEigen3 sym_eigen3(const glm::dmat3& a);

// Matrices decomposed side by side, kSymEigen3Lanes at a time: out[i] is bit for bit
// sym_eigen3(in[i]) (the same code, one lane of it), in about 0.6 of the time when there are
// several (each rotation's chain of divisions and square roots waits on the last; lanes
// overlap theirs). out.size() >= in.size().
inline constexpr int kSymEigen3Lanes = 4;
void sym_eigen3_lanes(std::span<const glm::dmat3> in, std::span<SymEigen3> out);

}  // namespace gauss
