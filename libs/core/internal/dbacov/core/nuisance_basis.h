// The nuisance self-calibration's flow-error basis (self_calibration.h, method nuisance), shared
// by the method (self_calibration.cpp) and the bootstrap that draws fields from it
// (dbacov/study/bootstrap.h). Internal.
#pragma once

#include <algorithm>
#include <cmath>

namespace dbacov {

/// The nuisance field's basis on the H × W grid, per channel: the affine [1, u, v] (group 0) and,
/// with nodes G >= 2, G × G bilinear tents (group 1), on u, v ∈ [−1, 1] (the grid's pixel centres
/// scaled by half its size). Each group has its own variance: a field is affine, or finer, or both.
/// A pixel touches the affine three and the four tents of its spline cell, so every sum over
/// pixels runs on those (active()) coordinates, cell by cell.
struct NuisanceBasis {
  int nodes = 0, H = 1, W = 1;
  int perChannel() const { return 3 + (nodes >= 2 ? nodes * nodes : 0); }
  int groups() const { return nodes >= 2 ? 2 : 1; }
  /// The group of coordinate k of an edge's field (channel-major: [x channel | y channel]).
  int groupOf(int k) const { return k % perChannel() < 3 ? 0 : 1; }
  int active() const { return nodes >= 2 ? 7 : 3; }  ///< basis functions non-zero at a pixel
  int cells() const { return nodes >= 2 ? (nodes - 1) * (nodes - 1) : 1; }
  /// The active coordinates of pixel (x, y) within a channel's perChannel() and their values;
  /// returns the pixel's spline cell (0 for the affine basis).
  int eval(int x, int y, int* index, double* value) const {
    const double u = (x - 0.5 * (W - 1)) / (0.5 * W), v = (y - 0.5 * (H - 1)) / (0.5 * H);
    index[0] = 0, index[1] = 1, index[2] = 2;
    value[0] = 1.0, value[1] = u, value[2] = v;
    if (nodes < 2) return 0;
    const double step = 2.0 / (nodes - 1);
    const double pu = (u + 1.0) / step, pv = (v + 1.0) / step;
    const int b = std::clamp(static_cast<int>(std::floor(pu)), 0, nodes - 2);
    const int a = std::clamp(static_cast<int>(std::floor(pv)), 0, nodes - 2);
    const double wu = pu - b, wv = pv - a;
    const int k0 = 3 + a * nodes + b;
    index[3] = k0, index[4] = k0 + 1, index[5] = k0 + nodes, index[6] = k0 + nodes + 1;
    value[3] = (1 - wv) * (1 - wu), value[4] = (1 - wv) * wu;
    value[5] = wv * (1 - wu), value[6] = wv * wu;
    return a * (nodes - 1) + b;
  }
  /// Within a spline cell every active value is a polynomial in the pixel's monomials m =
  /// [1, u, v] (affine) or [1, u, v, uv] (tents: bilinear in the cell): value = T_cell m. Sums
  /// over a cell's pixels can then run on the monomials() and be mapped by T_cell once.
  int monomials() const { return nodes >= 2 ? 4 : 3; }
  void monomial(int x, int y, double* m) const {
    const double u = (x - 0.5 * (W - 1)) / (0.5 * W), v = (y - 0.5 * (H - 1)) / (0.5 * H);
    m[0] = 1.0, m[1] = u, m[2] = v;
    if (nodes >= 2) m[3] = u * v;
  }
  /// T_cell, active() × monomials() row-major: with wu = α u + β_u, wv = α v + β_v in the cell
  /// (α = 1/step, β_u = 1/step − b, β_v = 1/step − a for the cell's column b and row a).
  void cellTransform(int cell, double* T) const {
    const int nm = monomials(), na = active();
    for (int i = 0; i < na * nm; ++i) T[i] = 0.0;
    T[0 * nm + 0] = 1.0, T[1 * nm + 1] = 1.0, T[2 * nm + 2] = 1.0;
    if (nodes < 2) return;
    const int b = cell % (nodes - 1), a = cell / (nodes - 1);
    const double al = (nodes - 1) / 2.0, bu = al - b, bv = al - a;
    // (c0 + c1 u)(d0 + d2 v) = c0 d0 + c1 d0 u + c0 d2 v + c1 d2 uv
    const auto product = [&](int row, double c0, double c1, double d0, double d2) {
      double* t = T + row * nm;
      t[0] = c0 * d0;
      t[1] = c1 * d0;
      t[2] = c0 * d2;
      t[3] = c1 * d2;
    };
    product(3, 1 - bu, -al, 1 - bv, -al);  // (1 − wu)(1 − wv)
    product(4, bu, al, 1 - bv, -al);       // wu (1 − wv)
    product(5, 1 - bu, -al, bv, al);       // (1 − wu) wv
    product(6, bu, al, bv, al);            // wu wv
  }
};

}  // namespace dbacov
