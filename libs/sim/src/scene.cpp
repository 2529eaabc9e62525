#include "dbacov/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dbacov::sim {

double RoomScene::inverseDepth(const Eigen::Isometry3d& T_wc, double xn, double yn) const {
  // Ray o + s·v (s = depth along the optical axis, since v's camera z component is 1).
  const Eigen::Vector3d o = T_wc.translation();
  const Eigen::Vector3d v = T_wc.linear() * Eigen::Vector3d(xn, yn, 1.0);
  double s_min = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(v[axis]) < 1e-12) continue;
    for (double wall : {min_corner[axis], max_corner[axis]}) {
      const double s = (wall - o[axis]) / v[axis];
      if (s > 1e-9) s_min = std::min(s_min, s);
    }
  }
  return std::isfinite(s_min) ? 1.0 / s_min : 0.0;
}

}  // namespace dbacov::sim
