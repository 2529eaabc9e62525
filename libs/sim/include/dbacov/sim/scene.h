// Ground-truth geometry of the simulator: a box-shaped room with texture-free walls and optional
// boxes standing in it; depth by ray casting.
#pragma once

#include <vector>

#include <Eigen/Geometry>

namespace dbacov::sim {

/// An axis-aligned box inside the room (world frame, metres).
struct Box {
  Eigen::Vector3d min_corner = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_corner = Eigen::Vector3d::Zero();
};

/// Camera convention everywhere in the simulator: pinhole looking along its +z, x right, y down;
/// T_wc maps camera to world coordinates.
struct RoomScene {
  Eigen::Vector3d min_corner{-3.0, -1.5, -2.0};  ///< world frame, metres
  Eigen::Vector3d max_corner{6.0, 1.5, 5.0};
  std::vector<Box> boxes;  ///< obstacles seen from outside (the camera must not be inside one)

  /// Inverse depth along the optical axis of the pixel ray from T_wc (ray = R [xn, yn, 1]): the
  /// nearest hit of a box's outside or of a wall, or 0 when the ray leaves the room (never for a
  /// camera inside it).
  double inverseDepth(const Eigen::Isometry3d& T_wc, double xn, double yn) const;

  /// Throws std::invalid_argument when a corner pair is not ordered (min < max on every axis) or a
  /// box reaches outside the room.
  void validate() const;
  /// True when the point lies strictly inside the room and outside every box.
  bool isFree(const Eigen::Vector3d& p) const;
};

}  // namespace dbacov::sim
