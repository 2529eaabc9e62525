// Ground-truth geometry of the simulator: a box-shaped room, depth by ray casting.
#pragma once

#include <Eigen/Geometry>

namespace dbacov::sim {

/// Camera convention everywhere in the simulator: pinhole looking along its +z, x right, y down;
/// T_wc maps camera to world coordinates.
struct RoomScene {
  Eigen::Vector3d min_corner{-3.0, -1.5, -2.0};  ///< world frame, metres
  Eigen::Vector3d max_corner{6.0, 1.5, 5.0};
  /// Inverse depth along the optical axis of the pixel ray from T_wc (ray = R [xn, yn, 1]), or 0
  /// when the ray leaves the room (never for a camera inside it).
  double inverseDepth(const Eigen::Isometry3d& T_wc, double xn, double yn) const;
};

}  // namespace dbacov::sim
