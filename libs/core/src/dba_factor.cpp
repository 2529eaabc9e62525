#include "dbacov/core/dba_factor.h"

namespace dbacov {

Eigen::Vector2d pixelFactorResidual(const Eigen::Isometry3d& T_wc_i,
                                    const Eigen::Isometry3d& T_wc_j, const PinholeIntrinsics& K,
                                    double x, double y, double d, double target_x,
                                    double target_y) {
  // Straight from conventions §2 with 4×4 homogeneous matrices, independent of
  // linearizePixelFactor.
  const Eigen::Matrix4d T_ji = (T_wc_j.inverse() * T_wc_i).matrix();
  const Eigen::Vector4d X((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0, d);
  const Eigen::Vector4d Y = T_ji * X;
  return Eigen::Vector2d(target_x - (K.fx * Y[0] / Y[2] + K.cx),
                         target_y - (K.fy * Y[1] / Y[2] + K.cy));
}

}  // namespace dbacov
