#include "dbacov/core/reprojection.h"

#include <algorithm>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/linearization.h"

namespace dbacov {

std::vector<WeightedError> reprojectionErrors(const Snapshot& s, const DbaOptions& o) {
  std::vector<WeightedError> out;
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const int HW = static_cast<int>(s.pixelsPerFrame());
  for (int e = 0; e < s.numEdges(); ++e) {
    const Eigen::Isometry3d T_ji =
        s.T_cw(static_cast<int>(s.jj[e])) * s.T_wc(static_cast<int>(s.ii[e]));
    for (int p = 0; p < HW; ++p) {
      const double wx = s.weightPlane(e, 0)[p], wy = s.weightPlane(e, 1)[p];
      const double d = s.disps[static_cast<std::size_t>(s.ii[e]) * HW + p];
      if ((wx == 0 && wy == 0) || !(d > 0)) continue;
      const Eigen::Vector3d Y =
          transferPoint(T_ji.linear(), T_ji.translation(), K, p % s.W, p / s.W, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      const Eigen::Vector2d r(s.targetPlane(e, 0)[p] - (K.fx * Y.x() / Y.z() + K.cx),
                              s.targetPlane(e, 1)[p] - (K.fy * Y.y() / Y.z() + K.cy));
      out.push_back({r.norm(), 0.5 * (wx + wy)});
    }
  }
  return out;
}

double weightedMedian(std::vector<WeightedError> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.error < b.error; });
  double total = 0;
  for (const auto& x : v) total += x.weight;
  double acc = 0;
  for (const auto& x : v) {
    acc += x.weight;
    if (acc >= 0.5 * total) return x.error;
  }
  return v.back().error;
}

}  // namespace dbacov
