// Inputs of `dba-evaluate`: ground-truth trajectories (TUM, EuRoC), the covariance tables of
// `dba-covariance` (--csv, --relative-csv) and its pose rawlogs (-o). Every parse error throws
// InputError naming the file, the line (or rawlog entry) and what was expected.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/se3.h"

namespace dbacov::app {

enum class GroundTruthFormat {
  Auto,   ///< EuRoC when the first data line has commas, else TUM
  Tum,    ///< "t tx ty tz qx qy qz qw" (seconds; camera-to-world), '#' comments
  Euroc,  ///< EuRoC state_groundtruth_estimate0/data.csv: "t[ns], px, py, pz, qw, qx, qy, qz, ..."
};
/// "auto", "tum", "euroc"; throws std::invalid_argument otherwise.
GroundTruthFormat parseGroundTruthFormat(const std::string& name);

/// A trajectory of camera-to-world poses sorted by time.
class GroundTruth {
 public:
  static GroundTruth load(const std::string& path,
                          GroundTruthFormat format = GroundTruthFormat::Auto);
  /// T_wc ← T_wc · T_body_cam for every pose (EuRoC's ground truth is the body frame; T_body_cam
  /// is the camera's T_BS from its sensor.yaml).
  void applyBodyToCamera(const Eigen::Isometry3d& T_body_cam);
  /// The pose at time t: the nearest sample when it is within `tolerance` seconds, else the
  /// interpolation (linear translation, slerp rotation) between the bracketing samples when they
  /// are at most `max_gap` apart; nullopt otherwise.
  std::optional<Eigen::Isometry3d> at(double t, double tolerance, double max_gap) const;
  std::size_t size() const { return t_.size(); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<double> t_;
  std::vector<Eigen::Isometry3d> T_;
};

/// Maps DROID's keyframe `tstamp` (an image index) to seconds: start + tstamp / fps, or the
/// time of image number `tstamp` in a list of image times.
class KeyframeTimes {
 public:
  static KeyframeTimes fromRate(double fps, double start);
  /// One time per line in seconds, or a CSV whose first column is in nanoseconds (EuRoC's
  /// cam0/data.csv, recognized by the comma); '#' lines are comments.
  static KeyframeTimes fromFile(const std::string& path);
  /// Throws InputError when tstamp is not an index of the list (list mode).
  double operator()(double tstamp) const;

 private:
  double fps_ = 0, start_ = 0;
  std::vector<double> times_;
  std::string path_;
};

struct KeyframeCovarianceRow {
  std::int64_t snapshot = 0;
  int keyframe = 0;
  double tstamp = 0;
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  Matrix6d Sigma = Matrix6d::Zero();  ///< tangent covariance (conventions §3)
  std::string where;                  ///< "file:line"
};
/// `dba-covariance --csv`: columns found by name in the header (snapshot, keyframe, tstamp,
/// tx..qw, cov_00..cov_55).
std::vector<KeyframeCovarianceRow> readKeyframeCsv(const std::string& path);

struct RelativeCovarianceRow {
  std::int64_t snapshot = 0;
  int from = 0, to = 0;
  Eigen::Isometry3d Z = Eigen::Isometry3d::Identity();  ///< T_wc_from⁻¹ T_wc_to
  Matrix6d Sigma = Matrix6d::Zero();
  std::string where;
};
/// `dba-covariance --relative-csv`: snapshot, from, to, tx..qw, cov_00..cov_55.
std::vector<RelativeCovarianceRow> readRelativeCsv(const std::string& path);

struct RawlogPoseRow {
  double t = 0;  ///< observation timestamp, seconds
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  Matrix6d Sigma =
      Matrix6d::Zero();  ///< tangent covariance, converted back from [x y z yaw pitch roll]
  std::size_t entry = 0;
};
/// Every CObservationRobotPose of a rawlog (directly or in a CSensoryFrame) whose sensorLabel is
/// `label` (any when empty). The covariance goes back to the tangent with the inverse of the one
/// conversion of pose_conversion.h: Σ = J⁻¹ Σ_ypr J⁻ᵀ, J = tangentToYprJacobian(T_wc).
std::vector<RawlogPoseRow> readPoseRawlog(const std::string& path, const std::string& label = "");

}  // namespace dbacov::app
