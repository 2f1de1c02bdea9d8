#include "gauss/engine/sym_eigen3.h"

#include <cmath>
#include <utility>

#include <glm/matrix.hpp>

namespace gauss {

SymEigen3 sym_eigen3(const glm::dmat3& a) {
  // m[r][c] row-major working copy of the symmetric matrix; v accumulates the rotations.
  double m[3][3];
  for (int c = 0; c < 3; ++c)
    for (int r = c; r < 3; ++r) m[r][c] = m[c][r] = a[c][r];
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

  SymEigen3 out;
  for (int sweep = 0; sweep < kSymEigen3MaxSweeps; ++sweep) {
    const double off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
    const double diag = m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2];
    // Converged when the off-diagonal part is below rounding of the diagonal (relative), or
    // exactly zero (covers the zero matrix, whose diagonal is zero too).
    if (off == 0.0 || off <= diag * 1e-34) break;
    out.sweeps = sweep + 1;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        const double apq = m[p][q];
        // Below rounding of the pair's diagonal: rotating would change nothing representable
        // (and could stall convergence on rounding noise), so the entry is taken as zero.
        if (std::abs(apq) <= 1e-18 * (std::abs(m[p][p]) + std::abs(m[q][q]))) {
          m[p][q] = m[q][p] = 0.0;
          continue;
        }
        // Rotation angle that zeroes m[p][q] (Golub & Van Loan, sym.schur2): t = tan(theta),
        // the smaller root, so |theta| <= pi/4 and the rotation never swaps the pair.
        const double theta = (m[q][q] - m[p][p]) / (2.0 * apq);
        double t;
        if (std::abs(theta) > 1e150)  // theta^2 would overflow; t ~ 1 / (2 theta)
          t = 0.5 / theta;
        else
          t = (theta >= 0.0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0);
        const double s = t * c;
        // m <- J^T m J with J the rotation in the (p, q) plane.
        for (int k = 0; k < 3; ++k) {
          const double mkp = m[k][p], mkq = m[k][q];
          m[k][p] = c * mkp - s * mkq;
          m[k][q] = s * mkp + c * mkq;
        }
        for (int k = 0; k < 3; ++k) {
          const double mpk = m[p][k], mqk = m[q][k];
          m[p][k] = c * mpk - s * mqk;
          m[q][k] = s * mpk + c * mqk;
        }
        m[p][q] = m[q][p] = 0.0;  // exact by construction; rounding would leave ~eps * |apq|
        for (int k = 0; k < 3; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
  }

  // Sort descending (3 elements: a fixed network), moving the eigenvector columns along.
  int order[3] = {0, 1, 2};
  auto less = [&](int i, int j) { return m[order[i]][order[i]] < m[order[j]][order[j]]; };
  if (less(0, 1)) std::swap(order[0], order[1]);
  if (less(1, 2)) std::swap(order[1], order[2]);
  if (less(0, 1)) std::swap(order[0], order[1]);
  for (int k = 0; k < 3; ++k) {
    out.values[k] = m[order[k]][order[k]];
    for (int r = 0; r < 3; ++r) out.vectors[k][r] = v[r][order[k]];
  }
  // A permutation may have made the basis left-handed; flipping one eigenvector's sign keeps
  // it an eigenvector and makes the basis a proper rotation.
  if (glm::determinant(out.vectors) < 0.0) out.vectors[2] = -out.vectors[2];
  return out;
}

}  // namespace gauss
