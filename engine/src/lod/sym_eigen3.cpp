#include "gauss/engine/sym_eigen3.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <utility>

#include <glm/matrix.hpp>

namespace gauss {
namespace {

constexpr int kLanes = kSymEigen3Lanes;

// Cyclic Jacobi on kLanes matrices side by side: lane l is a[l] (zero beyond `count`, which
// converges at once). Each lane takes exactly the steps it would take alone (it stops at its
// own convergence, skips its own negligible pairs), so its result does not depend on the
// others; and sym_eigen3 is one lane of this same code, so a batch gives the bits a single
// call gives, whatever the compiler makes of the lane loops. The lanes are only there so
// that their chains of divisions and square roots, each rotation waiting on the last, overlap:
// one matrix at a time the core sat waiting on them.
void jacobi_lanes(const glm::dmat3* a, SymEigen3* out, int count) {
  // m[r][c][l]: row-major working copy of lane l's symmetric matrix; v accumulates its
  // rotations.
  double m[3][3][kLanes];
  double v[3][3][kLanes];
  bool active[kLanes];
  int sweeps[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    for (int c = 0; c < 3; ++c)
      for (int r = c; r < 3; ++r) m[r][c][l] = m[c][r][l] = l < count ? a[l][c][r] : 0.0;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) v[r][c][l] = r == c ? 1.0 : 0.0;
    active[l] = true;
    sweeps[l] = 0;
  }

  for (int sweep = 0; sweep < kSymEigen3MaxSweeps; ++sweep) {
    bool any = false;
    for (int l = 0; l < kLanes; ++l) {
      if (!active[l]) continue;
      const double off = m[0][1][l] * m[0][1][l] + m[0][2][l] * m[0][2][l] + m[1][2][l] * m[1][2][l];
      const double diag = m[0][0][l] * m[0][0][l] + m[1][1][l] * m[1][1][l] + m[2][2][l] * m[2][2][l];
      // Converged when the off-diagonal part is below rounding of the diagonal (relative), or
      // exactly zero (covers the zero matrix, whose diagonal is zero too).
      if (off == 0.0 || off <= diag * 1e-34) {
        active[l] = false;
        continue;
      }
      sweeps[l] = sweep + 1;
      any = true;
    }
    if (!any) break;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        // Every lane's rotation first (no branch: the lanes' divisions and roots overlap),
        // then applied where it is due.
        double c[kLanes], s[kLanes];
        bool rotate[kLanes];
        for (int l = 0; l < kLanes; ++l) {
          const double apq = m[p][q][l];
          // Below rounding of the pair's diagonal: rotating would change nothing representable
          // (and could stall convergence on rounding noise), so the entry is taken as zero.
          const bool negligible = std::abs(apq) <= 1e-18 * (std::abs(m[p][p][l]) + std::abs(m[q][q][l]));
          rotate[l] = active[l] && !negligible;
          // Rotation angle that zeroes m[p][q] (Golub & Van Loan, sym.schur2): t = tan(theta),
          // the smaller root, so |theta| <= pi/4 and the rotation never swaps the pair. (A lane
          // that does not rotate may divide by zero here: IEEE, and its values go unused.)
          const double theta = (m[q][q][l] - m[p][p][l]) / (2.0 * apq);
          // Both roots computed, one kept (a select, not a branch): beyond 1e150 theta^2 would
          // overflow, and t ~ 1 / (2 theta).
          const double huge = 0.5 / theta;
          const double usual = (theta >= 0.0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
          const double t = std::abs(theta) > 1e150 ? huge : usual;
          c[l] = 1.0 / std::sqrt(t * t + 1.0);
          s[l] = t * c[l];
          if (active[l] && negligible) m[p][q][l] = m[q][p][l] = 0.0;
        }
        for (int l = 0; l < kLanes; ++l) {
          if (!rotate[l]) continue;
          // m <- J^T m J with J the rotation in the (p, q) plane.
          for (int k = 0; k < 3; ++k) {
            const double mkp = m[k][p][l], mkq = m[k][q][l];
            m[k][p][l] = c[l] * mkp - s[l] * mkq;
            m[k][q][l] = s[l] * mkp + c[l] * mkq;
          }
          for (int k = 0; k < 3; ++k) {
            const double mpk = m[p][k][l], mqk = m[q][k][l];
            m[p][k][l] = c[l] * mpk - s[l] * mqk;
            m[q][k][l] = s[l] * mpk + c[l] * mqk;
          }
          m[p][q][l] = m[q][p][l] = 0.0;  // exact by construction; rounding would leave ~eps * |apq|
          for (int k = 0; k < 3; ++k) {
            const double vkp = v[k][p][l], vkq = v[k][q][l];
            v[k][p][l] = c[l] * vkp - s[l] * vkq;
            v[k][q][l] = s[l] * vkp + c[l] * vkq;
          }
        }
      }
    }
  }

  for (int l = 0; l < count; ++l) {
    SymEigen3& e = out[l];
    e.sweeps = sweeps[l];
    // Sort descending (3 elements: a fixed network), moving the eigenvector columns along.
    int order[3] = {0, 1, 2};
    auto less = [&](int i, int j) { return m[order[i]][order[i]][l] < m[order[j]][order[j]][l]; };
    if (less(0, 1)) std::swap(order[0], order[1]);
    if (less(1, 2)) std::swap(order[1], order[2]);
    if (less(0, 1)) std::swap(order[0], order[1]);
    for (int k = 0; k < 3; ++k) {
      e.values[k] = m[order[k]][order[k]][l];
      for (int r = 0; r < 3; ++r) e.vectors[k][r] = v[r][order[k]][l];
    }
    // A permutation may have made the basis left-handed; flipping one eigenvector's sign keeps
    // it an eigenvector and makes the basis a proper rotation.
    if (glm::determinant(e.vectors) < 0.0) e.vectors[2] = -e.vectors[2];
  }
}

}  // namespace

SymEigen3 sym_eigen3(const glm::dmat3& a) {
  SymEigen3 out;
  jacobi_lanes(&a, &out, 1);
  return out;
}

void sym_eigen3_lanes(std::span<const glm::dmat3> in, std::span<SymEigen3> out) {
  assert(out.size() >= in.size());
  for (std::size_t i = 0; i < in.size(); i += kLanes)
    jacobi_lanes(in.data() + i, out.data() + i, int(std::min<std::size_t>(kLanes, in.size() - i)));
}

}  // namespace gauss
