// The nuisance self-calibration's flow-error basis (self_calibration.h, method nuisance), shared
// by the method (self_calibration.cpp) and the bootstrap that draws fields from it
// (dbacov/sim/bootstrap.h). Internal.
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
};

}  // namespace dbacov
