// Options of the covariance engine: measurement weighting, pixel filters and gauge (SPEC §2, §4).
#pragma once

#include <optional>
#include <string>

namespace dbacov {

/// How the 7-DoF gauge of monocular DBA (6 pose + scale) is fixed (SPEC §4).
struct GaugeOptions {
  enum class Type {
    /// Gaussian prior on the two lowest-indexed keyframes that appear in `ii`, centred on their
    /// estimate, diagonal in the tangent [ρ; φ]. A sigma of 0 hard-fixes those components (the
    /// variables are removed; their covariance is reported as exactly zero).
    TwoPose,
    /// Hard-fix the first such keyframe (6 DoF) and only the distance between the first two
    /// keyframe centres (scale, 1 DoF): the second keyframe keeps 5 free DoF.
    Minimal,
    /// DROID-SLAM's own gauge in that update: hard-fix every graph keyframe below the snapshot's
    /// `t0` = max(1, min(ii) + 1) (DROID's BA optimizes only poses t0..t1−1). Needs the key 't0'.
    Droid,
  };
  Type type = Type::TwoPose;
  double sigma_rot = 0.0;    ///< radians, TwoPose only
  double sigma_trans = 0.0;  ///< snapshot length units, TwoPose only
};

struct DbaOptions {
  /// Information of a pixel factor is weight_scale · diag(w_x, w_y), in px^-2.
  double weight_scale = 1e-3;
  /// DROID's rule: drop a pixel factor when Y2 = z_j·d < min_depth_ratio. Unset: no such rule.
  std::optional<double> min_depth_ratio = 0.25;
  /// Keep a pixel factor only if d < 1/near and its metric depth in frame j, Y2/d, is > near.
  std::optional<double> near;
  /// Keep a pixel factor only if d > 1/far.
  std::optional<double> far;
  /// Depth variables with Hdd <= depth_info_eps are unobservable; they are not eliminated and
  /// their factors contribute only through the pose block (b_k is then negligible, see
  /// linearization.cpp).
  double depth_info_eps = 1e-12;
  /// RGB-D (snapshot key 'disps_sens'): information α of the depth-sensor factor
  /// α·(d − d_sens)² on every source pixel with d_sens > 0, in (inverse depth)^-2. DROID's BA
  /// (droid_kernels.cu) uses α = 0.05 with its 0.001-weighted reprojection factors; 0 = off.
  double sensor_depth_weight = 0.05;
  GaugeOptions gauge;

  /// DROID-SLAM's own DBA: weight_scale 0.001, Y2 >= 0.25, two-pose gauge hard-fixed.
  static DbaOptions droid();
  /// The paper's code path, corrected: weight_scale 0.1, near 0.25 / far 2 depth filter, two-pose
  /// gauge with sigmas 1° (rotation) and 0.05 (translation).
  static DbaOptions paper();
  /// "droid" or "paper"; throws std::invalid_argument for anything else.
  static DbaOptions preset(const std::string& name);

  /// Throws std::invalid_argument when a value is out of its domain (non-positive weight scale,
  /// negative sigmas, near >= far, ...).
  void validate() const;
};

}  // namespace dbacov
