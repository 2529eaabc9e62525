// Camera trajectories of the simulator (ground truth, camera-to-world, metres and radians).
#pragma once

#include <string>

#include <Eigen/Geometry>

namespace dbacov::sim {

enum class TrajectoryType {
  /// Forward along world +x, looking along world +z, with a slow yaw wave (every DoF excited).
  Line,
  /// Circles around the room centre looking outwards, `keyframes_per_lap` per lap, with a slowly
  /// breathing radius and height: every lap revisits the views of the previous ones.
  Loop,
  /// Out along world +x for the first half, then back facing the same way (EuRoC V2_03-like):
  /// on the way back the new keyframes overlap the old ones.
  ExploreReturn,
};

/// "line", "loop", "explore-return"; throws std::invalid_argument otherwise.
TrajectoryType parseTrajectoryType(const std::string& name);
/// The name parseTrajectoryType reads.
std::string toString(TrajectoryType type);

struct TrajectoryConfig {
  TrajectoryType type = TrajectoryType::Line;
  int num_keyframes = 8;        ///< length (ExploreReturn turns around at the middle)
  double step = 0.12;           ///< metres between consecutive keyframes (Line, ExploreReturn)
  double yaw_amplitude = 0.15;  ///< radians of the slow yaw wave (Line, ExploreReturn)
  Eigen::Vector3d loop_center{1.5, 0.0, 1.5};
  double loop_radius = 1.0;
  int keyframes_per_lap = 60;
};

/// Camera-to-world pose of keyframe k.
Eigen::Isometry3d trajectoryPose(const TrajectoryConfig& config, int k);

}  // namespace dbacov::sim
