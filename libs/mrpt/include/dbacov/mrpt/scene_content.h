// What a scene shows (keyframes, covariances, co-visibility) and how (SceneStyle), without any
// MRPT type: the apps fill these and hand them to the bridge (bridge.h), which draws them with
// MRPT (scene.h says what is drawn and in which frame).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/se3.h"

namespace dbacov::mrpt_bridge {

struct SceneKeyframe {
  std::string name;  ///< used in object names ("frustum <name>")
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  Matrix6d Sigma = Matrix6d::Zero();  ///< tangent covariance [ρ; φ] (conventions §3); zero = fixed
  bool gauge = false;                 ///< a gauge keyframe: drawn in grey
};

struct SceneContent {
  std::vector<SceneKeyframe> keyframes;        ///< in time order (the trajectory's order)
  std::vector<std::pair<int, int>> covisible;  ///< indices into `keyframes`
  Eigen::Vector4d intrinsics{1, 1, 0, 0};      ///< fx fy cx cy of the W×H pixel grid
  int W = 1, H = 1;
  std::vector<Eigen::Vector3f> points;  ///< world frame, optional
  std::vector<std::string> caption;     ///< first legend lines (what is shown)
};

struct SceneStyle {
  double sigma = 3;              ///< ellipsoid level: the sigma-sigma surface
  double exaggeration = 0;       ///< ellipsoid size factor; 0 = autoExaggeration()
  double frustum_depth = 0;      ///< far-plane distance; 0 = 0.6 × the median keyframe spacing
  Eigen::Vector3d up{0, -1, 0};  ///< world direction displayed up (a unit axis ±x, ±y, ±z)
  double legend_px = 14;         ///< legend character size in pixels
  /// Throws std::invalid_argument for sigma, legend_px <= 0, negative exaggeration or frustum
  /// depth (0 = auto), or an `up` that is not a signed unit axis.
  void validate() const;
};

}  // namespace dbacov::mrpt_bridge
