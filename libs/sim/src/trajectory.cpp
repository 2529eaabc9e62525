#include "dbacov/sim/trajectory.h"

#include <cmath>
#include <stdexcept>

namespace dbacov::sim {

TrajectoryType parseTrajectoryType(const std::string& name) {
  if (name == "line") return TrajectoryType::Line;
  if (name == "loop") return TrajectoryType::Loop;
  if (name == "explore-return") return TrajectoryType::ExploreReturn;
  throw std::invalid_argument("unknown trajectory '" + name +
                              "', expected line, loop or explore-return");
}

std::string toString(TrajectoryType type) {
  switch (type) {
    case TrajectoryType::Line:
      return "line";
    case TrajectoryType::Loop:
      return "loop";
    case TrajectoryType::ExploreReturn:
      return "explore-return";
  }
  return "?";
}

namespace {

/// Small attitude wobble so that no rotation DoF is degenerate.
Eigen::Matrix3d wobble(double t, double yaw_amplitude) {
  return (Eigen::AngleAxisd(yaw_amplitude * std::sin(0.4 * t), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(0.03 * std::sin(0.9 * t), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(0.02 * std::cos(0.6 * t), Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

}  // namespace

Eigen::Isometry3d trajectoryPose(const TrajectoryConfig& c, int k) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double t = static_cast<double>(k);
  switch (c.type) {
    case TrajectoryType::Line:
      T.translation() << c.step * t, 0.05 * std::sin(0.7 * t), 0.03 * std::cos(0.5 * t);
      T.linear() = wobble(t, c.yaw_amplitude);
      break;
    case TrajectoryType::ExploreReturn: {
      // Position along x: out for the first half, back for the second; a lateral offset of 0.1 m
      // on the way back keeps the baseline between overlapping keyframes non-zero.
      const int half = (c.num_keyframes + 1) / 2;
      const double s = k < half ? t : 2.0 * (half - 1) - t;
      const double back = k < half ? 0.0 : 1.0;
      T.translation() << c.step * s, 0.05 * std::sin(0.7 * t) + 0.1 * back,
          0.03 * std::cos(0.5 * t);
      T.linear() = wobble(t, c.yaw_amplitude);
      break;
    }
    case TrajectoryType::Loop: {
      const double theta = 2.0 * M_PI * t / c.keyframes_per_lap;
      const double slow = 2.0 * M_PI * t / (7.3 * c.keyframes_per_lap);
      const double r = c.loop_radius * (1.0 + 0.25 * std::sin(slow));
      const Eigen::Vector3d z(std::cos(theta), 0.0, std::sin(theta));  // optical axis, outwards
      const Eigen::Vector3d y = Eigen::Vector3d::UnitY();
      T.translation() = c.loop_center + r * z + Eigen::Vector3d(0, 0.2 * std::sin(1.3 * slow), 0);
      Eigen::Matrix3d R;
      R << y.cross(z), y, z;
      T.linear() = R * wobble(t, 0.05);
      break;
    }
  }
  return T;
}

}  // namespace dbacov::sim
