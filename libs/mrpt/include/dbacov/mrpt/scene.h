// 3D scenes of keyframe poses and their covariances for MRPT viewers (conventions §3, §6).
//
// What buildScene() draws, and in which frame:
//  - Display frame. All content lies in the world frame of the snapshots, inside one CSetOfObjects
//    named "world" whose pose is the fixed rotation displayRotation(up): it turns the world axis
//    `up` into the display +Z, around which MRPT viewers orbit. The default up is world −y: DROID's
//    world is its first camera (x right, y down, z forward), so image-up is shown up. The ground
//    grid ("grid") lies in the display XY plane, just below the content.
//  - Frustums. A dbacov camera looks along its +z with x right and y down; a CFrustum looks along
//    its local +X, spreads its horizontal FOV along ±Y and its vertical FOV along ±Z. Keyframe k's
//    frustum has the pose frustumPose(T_wc) = T_wc · R_cf, R_cf = [z_c  −x_c  −y_c] (frustum X =
//    camera z, Y = camera −x, Z = camera −y), and the field of view of the intrinsics over the
//    pixel grid (asymmetric when the principal point is off-centre), so its far-plane corners
//    project onto the image corners (−½, −½) … (W−½, H−½).
//  - Ellipsoids. Right perturbation T_wc·Exp(ξ), ξ = [ρ; φ]: the camera centre moves by
//    δp_world = R_wc ρ, so its world-frame covariance is Σ_pos = R_wc Σ[0:3,0:3] R_wcᵀ
//    (worldPositionCovariance; it equals the position block of MRPT's [x y z yaw pitch roll]
//    covariance, mrpt_bridge::toPoseGaussian). The ellipsoid is the `sigma`-sigma surface of
//    exaggeration² · Σ_pos centred on the camera. posePDF2opengl(CPose3DPDFGaussian) is not used:
//    it rotates that world-frame covariance by the mean's rotation once more.
//    MRPT 2.5.8's CEllipsoid3D draws the unit sphere mapped by the upper Cholesky factor U of its
//    matrix C = UᵀU, i.e. the ellipsoid of U·Uᵀ, which differs from C's when C is not diagonal
//    (checked in tests/viz). So each CEllipsoid3D gets a diagonal matrix (where U·Uᵀ = C) of the
//    eigenvalues of Σ_pos divided by the largest, its pose is (camera centre, eigenvectors of
//    Σ_pos), and a uniform scale exaggeration·sqrt(λ_max) restores the size (MRPT treats a matrix
//    with |det| < 1e-20 as zero, which tiny covariances would hit). Eigenvalues below 1e-6·λ_max
//    are raised to it (a rank-deficient covariance becomes a thin disc). A keyframe whose Σ_pos is
//    zero (hard-fixed by the gauge) gets no ellipsoid.
//  - Lines: the trajectory through the camera centres in keyframe order ("trajectory"), one segment
//    per co-visible pair ("covisibility"); optionally a coloured point cloud ("points"). Empty
//    parts are left out (MRPT cannot render an empty line set): no "world" set without keyframes.
//  - Legend: text messages of the main viewport (they are saved with the scene and drawn by
//    CFBORender), stating the sigma level and the exaggeration factor.
// Object names: "frustum <name>", "ellipsoid <name>" with SceneKeyframe::name.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <mrpt/opengl/COpenGLScene.h>
#include <Eigen/Geometry>

#include "dbacov/core/se3.h"
#include "dbacov/mrpt/scene_content.h"

namespace dbacov::mrpt_bridge {

/// Σ_pos = R_wc Σ[0:3,0:3] R_wcᵀ: covariance of the camera centre in world coordinates.
Eigen::Matrix3d worldPositionCovariance(const Eigen::Isometry3d& T_wc, const Matrix6d& Sigma);

/// Pose of a CFrustum drawn for a camera at T_wc: T_wc · R_cf, R_cf = [z_c  −x_c  −y_c].
Eigen::Isometry3d frustumPose(const Eigen::Isometry3d& T_wc);

/// Rotation R_dw with R_dw · up = +Z (display frame ← world frame); `up` a signed unit axis.
Eigen::Matrix3d displayRotation(const Eigen::Vector3d& up);

/// Median distance between consecutive keyframe centres (0 with fewer than two keyframes).
double medianKeyframeSpacing(const SceneContent& content);

/// The largest factor of the 1-2-5 series (…, 0.5, 1, 2, 5, 10, …) with which the median (over
/// keyframes) of the largest sigma-sigma semi-axis is at most 0.4 × the median keyframe spacing;
/// 1 when there is nothing to scale (no covariance, fewer than two keyframes).
double autoExaggeration(const SceneContent& content, double sigma);

/// The legend's ellipsoid line, e.g. "ellipsoids: 3-sigma world position covariance x 20".
std::string ellipsoidLegend(double sigma, double exaggeration);

/// Builds the scene described above (style.exaggeration 0 → autoExaggeration). Throws
/// std::invalid_argument for an invalid style or out-of-range co-visibility indices.
mrpt::opengl::COpenGLScene::Ptr buildScene(const SceneContent& content, const SceneStyle& style);

}  // namespace dbacov::mrpt_bridge
