// Private helpers of the scene builder and renderer (dbacov_mrpt only).
#pragma once

#include <string>
#include <vector>

#include <mrpt/opengl/CEllipsoid3D.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/opengl/CPointCloudColoured.h>
#include <Eigen/Core>

#include "dbacov/mrpt/scene.h"

namespace dbacov::mrpt_bridge::detail {

/// Median / q-quantile (nearest rank) of a non-empty sample (copied).
double median(std::vector<double> v);
double quantile(std::vector<double> v, double q);
/// The smallest 1-2-5 value >= x (x > 0).
double niceStep(double x);

/// The style with its automatic values (exaggeration, frustum depth) filled in; validates.
SceneStyle resolveStyle(const SceneContent& content, SceneStyle style);

/// The sigma-sigma ellipsoid of exaggeration²·Sigma_pos at `centre` (see scene.h for the encoding
/// that works around CEllipsoid3D's Cholesky orientation); nullptr when Sigma_pos is zero.
mrpt::opengl::CEllipsoid3D::Ptr makeEllipsoid(const Eigen::Vector3d& centre,
                                              const Eigen::Matrix3d& Sigma_pos, double sigma,
                                              double exaggeration);

/// World points of the content: camera centres, far-plane corners of the frustums, the
/// ellipsoids' bounding boxes and, `with_points`, the central 80% box of the point cloud (the
/// grid covers it; the fitted view does not, so that the estimate stays large in the picture).
std::vector<Eigen::Vector3d> worldExtent(const SceneContent& content, const SceneStyle& resolved,
                                         bool with_points);

/// The point cloud ("points"), coloured by display height (5–95% range mapped to a colour ramp).
mrpt::opengl::CPointCloudColoured::Ptr makePointCloud(const std::vector<Eigen::Vector3f>& points,
                                                      const Eigen::Matrix3d& R_dw);

/// Legend lines (caption, object colours, ellipsoid level and exaggeration, grid step) as text
/// messages of the main viewport, top-left.
void addLegend(mrpt::opengl::COpenGLScene& scene, const std::vector<std::string>& caption,
               const SceneStyle& resolved, int ellipsoids, const std::string& grid_line);

}  // namespace dbacov::mrpt_bridge::detail
