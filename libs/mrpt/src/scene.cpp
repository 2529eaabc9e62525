#include "dbacov/mrpt/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <mrpt/opengl/CEllipsoid3D.h>
#include <mrpt/opengl/CFrustum.h>
#include <mrpt/opengl/CGridPlaneXY.h>
#include <mrpt/opengl/CPointCloudColoured.h>
#include <mrpt/opengl/CSetOfLines.h>
#include <mrpt/opengl/CSetOfObjects.h>
#include <Eigen/Eigenvalues>

#include "dbacov/mrpt/pose_conversion.h"
#include "scene_internal.h"

namespace dbacov::mrpt_bridge {
namespace {

using mrpt::opengl::CSetOfObjects;

// Colours of the legend and of the objects it names.
const mrpt::img::TColor kTrajectory(20, 20, 20), kCovisible(140, 200, 140), kFrustum(30, 80, 200),
    kNewest(220, 30, 30), kGauge(150, 150, 150), kEllipsoid(255, 130, 0, 140), kGrid(205, 205, 205);

mrpt::math::TPoint3D toPoint(const Eigen::Vector3d& p) {
  return {p.x(), p.y(), p.z()};
}

/// Half-angles (degrees) of the frustum of a W×H pixel grid (pixel centres at integer
/// coordinates, so the image spans [−½, W−½] × [−½, H−½]).
struct FieldOfView {
  double left, right, up, down;  // image left (camera −x), right, up (camera −y), down
};
FieldOfView fieldOfView(const Eigen::Vector4d& K, int W, int H) {
  const double fx = K[0], fy = K[1], cx = K[2], cy = K[3];
  auto deg = [](double a) { return a * 180.0 / M_PI; };
  return {deg(std::atan2(cx + 0.5, fx)), deg(std::atan2(W - 0.5 - cx, fx)),
          deg(std::atan2(cy + 0.5, fy)), deg(std::atan2(H - 0.5 - cy, fy))};
}

mrpt::opengl::CFrustum::Ptr makeFrustum(const SceneKeyframe& kf, const FieldOfView& fov,
                                        double depth, const mrpt::img::TColor& colour) {
  auto f = mrpt::opengl::CFrustum::Create();
  f->setNearFarPlanes(static_cast<float>(1e-3 * depth), static_cast<float>(depth));
  // CFrustum's first horizontal angle spreads along its −Y (= camera +x, image right), the second
  // along +Y (= camera −x, image left); vertically the first along −Z (camera +y, image down).
  f->setHorzFOVAsymmetric(static_cast<float>(fov.right), static_cast<float>(fov.left));
  f->setVertFOVAsymmetric(static_cast<float>(fov.down), static_cast<float>(fov.up));
  f->setLineWidth(1.5f);
  f->setColor_u8(colour);
  f->setPose(toCPose3D(frustumPose(kf.T_wc)));
  f->setName("frustum " + kf.name);
  return f;
}

}  // namespace

Eigen::Matrix3d worldPositionCovariance(const Eigen::Isometry3d& T_wc, const Matrix6d& Sigma) {
  const Eigen::Matrix3d& R = T_wc.linear();
  const Eigen::Matrix3d C = R * Sigma.topLeftCorner<3, 3>() * R.transpose();
  return 0.5 * (C + C.transpose());
}

Eigen::Isometry3d frustumPose(const Eigen::Isometry3d& T_wc) {
  Eigen::Matrix3d R_cf;
  R_cf.col(0) = Eigen::Vector3d::UnitZ();   // frustum +X: the optical axis
  R_cf.col(1) = -Eigen::Vector3d::UnitX();  // frustum +Y: image left
  R_cf.col(2) = -Eigen::Vector3d::UnitY();  // frustum +Z: image up
  Eigen::Isometry3d T = T_wc;
  T.linear() = T_wc.linear() * R_cf;
  return T;
}

Eigen::Matrix3d displayRotation(const Eigen::Vector3d& up) {
  // Rows of R_dw: display X, Y, Z in world coordinates; Z = up, X the first world axis ⟂ up.
  const Eigen::Vector3d z = up.normalized();
  const Eigen::Vector3d x =
      std::abs(z.x()) > 0.5 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  Eigen::Matrix3d R;
  R.row(0) = x.transpose();
  R.row(1) = z.cross(x).transpose();
  R.row(2) = z.transpose();
  return R;
}

double medianKeyframeSpacing(const SceneContent& c) {
  std::vector<double> d;
  for (std::size_t k = 1; k < c.keyframes.size(); ++k)
    d.push_back((c.keyframes[k].T_wc.translation() - c.keyframes[k - 1].T_wc.translation()).norm());
  return d.empty() ? 0.0 : detail::median(d);
}

double autoExaggeration(const SceneContent& c, double sigma) {
  const double spacing = medianKeyframeSpacing(c);
  std::vector<double> axes;
  for (const auto& kf : c.keyframes) {
    const double lmax = worldPositionCovariance(kf.T_wc, kf.Sigma)
                            .selfadjointView<Eigen::Lower>()
                            .eigenvalues()
                            .maxCoeff();
    if (lmax > 0 && std::isfinite(lmax)) axes.push_back(sigma * std::sqrt(lmax));
  }
  if (!(spacing > 0) || axes.empty()) return 1.0;
  const double wanted = 0.4 * spacing / detail::median(axes);
  // Largest 1-2-5 value not above `wanted`.
  const double decade = std::pow(10.0, std::floor(std::log10(wanted)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * decade <= wanted * (1 + 1e-12)) return m * decade;
  return decade;
}

std::string ellipsoidLegend(double sigma, double exaggeration) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "ellipsoids: %g-sigma world position covariance, scaled x %g",
                sigma, exaggeration);
  return buf;
}

SceneStyle detail::resolveStyle(const SceneContent& c, SceneStyle s) {
  s.validate();
  if (s.exaggeration == 0) s.exaggeration = autoExaggeration(c, s.sigma);
  if (s.frustum_depth == 0) {
    double spacing = medianKeyframeSpacing(c);
    if (!(spacing > 0)) spacing = 1.0;
    s.frustum_depth = 0.6 * spacing;
  }
  return s;
}

mrpt::opengl::CEllipsoid3D::Ptr detail::makeEllipsoid(const Eigen::Vector3d& centre,
                                                      const Eigen::Matrix3d& Sigma_pos,
                                                      double sigma, double exaggeration) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Sigma_pos);
  const Eigen::Vector3d lambda = es.eigenvalues();
  const double lmax = lambda.maxCoeff();
  if (!(lmax > 0) || !std::isfinite(lmax)) return nullptr;
  Eigen::Matrix3d V = es.eigenvectors();
  if (V.determinant() < 0) V.col(0) = -V.col(0);  // a rotation
  mrpt::math::CMatrixDouble33 D;
  D.setZero();
  for (int i = 0; i < 3; ++i) D(i, i) = std::max(lambda[i] / lmax, 1e-6);
  auto e = mrpt::opengl::CEllipsoid3D::Create();
  e->setCovMatrix(D);
  e->setQuantiles(static_cast<float>(sigma));
  e->setScale(static_cast<float>(exaggeration * std::sqrt(lmax)));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = V;
  pose.translation() = centre;
  e->setPose(toCPose3D(pose));
  return e;
}

std::vector<Eigen::Vector3d> detail::worldExtent(const SceneContent& c, const SceneStyle& s,
                                                 bool with_points) {
  std::vector<Eigen::Vector3d> pts;
  const FieldOfView fov = fieldOfView(c.intrinsics, c.W, c.H);
  const double tl = std::tan(fov.left * M_PI / 180), tr = std::tan(fov.right * M_PI / 180);
  const double tu = std::tan(fov.up * M_PI / 180), td = std::tan(fov.down * M_PI / 180);
  for (const auto& kf : c.keyframes) {
    pts.push_back(kf.T_wc.translation());
    for (const Eigen::Vector3d& corner : {Eigen::Vector3d(-tl, -tu, 1), Eigen::Vector3d(tr, -tu, 1),
                                          Eigen::Vector3d(-tl, td, 1), Eigen::Vector3d(tr, td, 1)})
      pts.push_back(kf.T_wc * (s.frustum_depth * corner));
    const Eigen::Matrix3d C = worldPositionCovariance(kf.T_wc, kf.Sigma);
    for (int i = 0; i < 3; ++i) {  // the ellipsoid's bounding box: ± sigma·f·sqrt(C_ii) per axis
      const double h = s.sigma * s.exaggeration * std::sqrt(std::max(C(i, i), 0.0));
      pts.push_back(kf.T_wc.translation() + h * Eigen::Vector3d::Unit(i));
      pts.push_back(kf.T_wc.translation() - h * Eigen::Vector3d::Unit(i));
    }
  }
  if (with_points && !c.points.empty()) {  // the central 80% of the cloud per axis
    Eigen::Vector3d lo, hi;
    for (int i = 0; i < 3; ++i) {
      std::vector<double> v;
      for (const auto& p : c.points) v.push_back(p[i]);
      lo[i] = detail::quantile(v, 0.1);
      hi[i] = detail::quantile(v, 0.9);
    }
    for (int m = 0; m < 8; ++m)
      pts.emplace_back(m & 1 ? hi.x() : lo.x(), m & 2 ? hi.y() : lo.y(), m & 4 ? hi.z() : lo.z());
  }
  return pts;
}

mrpt::opengl::COpenGLScene::Ptr buildScene(const SceneContent& c, const SceneStyle& style) {
  const SceneStyle s = detail::resolveStyle(c, style);
  const int n = static_cast<int>(c.keyframes.size());
  for (const auto& [a, b] : c.covisible)
    if (a < 0 || b < 0 || a >= n || b >= n)
      throw std::invalid_argument("buildScene: co-visible pair out of range");
  const Eigen::Matrix3d R_dw = displayRotation(s.up);

  auto scene = mrpt::opengl::COpenGLScene::Create();
  auto world = CSetOfObjects::Create();
  world->setName("world");
  Eigen::Isometry3d T_dw = Eigen::Isometry3d::Identity();
  T_dw.linear() = R_dw;
  world->setPose(toCPose3D(T_dw));

  auto trajectory = mrpt::opengl::CSetOfLines::Create();
  trajectory->setName("trajectory");
  trajectory->setColor_u8(kTrajectory);
  trajectory->setLineWidth(3.0f);
  for (int k = 1; k < n; ++k)
    trajectory->appendLine(toPoint(c.keyframes[k - 1].T_wc.translation()),
                           toPoint(c.keyframes[k].T_wc.translation()));
  auto covisible = mrpt::opengl::CSetOfLines::Create();
  covisible->setName("covisibility");
  covisible->setColor_u8(kCovisible);
  covisible->setLineWidth(1.0f);
  for (const auto& [a, b] : c.covisible)
    covisible->appendLine(toPoint(c.keyframes[a].T_wc.translation()),
                          toPoint(c.keyframes[b].T_wc.translation()));
  // MRPT cannot bound (and so cannot render) empty line sets or sets of objects: insert only
  // what has content.
  // Drawn first, the trajectory wins where a co-visibility segment coincides with it.
  if (n > 1) world->insert(trajectory);
  if (!c.covisible.empty()) world->insert(covisible);

  const FieldOfView fov = fieldOfView(c.intrinsics, c.W, c.H);
  int ellipsoids = 0;
  for (int k = 0; k < n; ++k) {
    const SceneKeyframe& kf = c.keyframes[k];
    const auto& colour = kf.gauge ? kGauge : (k == n - 1 ? kNewest : kFrustum);
    world->insert(makeFrustum(kf, fov, s.frustum_depth, colour));
    auto e = detail::makeEllipsoid(
        kf.T_wc.translation(), worldPositionCovariance(kf.T_wc, kf.Sigma), s.sigma, s.exaggeration);
    if (!e) continue;
    e->setName("ellipsoid " + kf.name);
    e->enableDrawSolid3D(true);
    e->setColor_u8(kEllipsoid);
    world->insert(e);
    ++ellipsoids;
  }
  if (!c.points.empty()) world->insert(detail::makePointCloud(c.points, R_dw));
  if (n > 0) scene->insert(world);

  // Ground grid below the content (display frame), on a 1-2-5 spacing.
  const std::vector<Eigen::Vector3d> extent = detail::worldExtent(c, s, true);
  std::string grid_line;
  if (!extent.empty()) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
    for (const auto& p : extent) {
      lo = lo.cwiseMin(R_dw * p);
      hi = hi.cwiseMax(R_dw * p);
    }
    const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-9});
    const double step = detail::niceStep(span / 8);
    auto grid = mrpt::opengl::CGridPlaneXY::Create(
        static_cast<float>(std::floor(lo.x() / step - 1) * step),
        static_cast<float>(std::ceil(hi.x() / step + 1) * step),
        static_cast<float>(std::floor(lo.y() / step - 1) * step),
        static_cast<float>(std::ceil(hi.y() / step + 1) * step),
        static_cast<float>(lo.z() - 0.05 * span), static_cast<float>(step));
    grid->setName("grid");
    grid->setColor_u8(kGrid);
    scene->insert(grid);
    char line[96];
    std::snprintf(line, sizeof line, "grid: %g units", step);
    grid_line = line;
  }
  detail::addLegend(*scene, c.caption, s, ellipsoids, grid_line);
  return scene;
}

}  // namespace dbacov::mrpt_bridge
