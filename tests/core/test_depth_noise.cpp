// The depths' second-order noise term (depth_noise.h): its Jacobian derivatives against finite
// differences, its sums against a dense reference built factor by factor with finite-difference
// derivatives (no Γ, no adjoint, no edge coordinates), and its claim by Monte Carlo.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_factor.h"
#include "dbacov/core/depth_noise.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/sim/consistency.h"
#include "dbacov/sim/monte_carlo.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/sensor_modes.h"
#include "kernel_variants.h"

namespace dbacov {
namespace {

TEST(DepthNoise, JacobianDepthDerivativeMatchesFiniteDifferences) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const PinholeIntrinsics K{320, 300, 160, 120};
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(0.3 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized())
            .toRotationMatrix();
    const Eigen::Vector3d t(0.5 * u(rng), 0.5 * u(rng), 0.3 * u(rng));
    const double x = 160 + 150 * u(rng), y = 120 + 110 * u(rng), d = 0.6 + 0.5 * u(rng);
    const auto at = [&](double dd) {
      PixelFactorLinearization f;
      linearizePixelFactorAt(transferPoint(R, t, K, x, y, dd), t, K, dd, 0.0, 0.0, &f);
      return f;
    };
    const double h = 1e-6;
    const PixelFactorLinearization fp = at(d + h), fm = at(d - h);
    const Eigen::Matrix<double, 2, 6> fd = (fp.J_j - fm.J_j) / (2 * h);
    const Eigen::Vector2d fd_rdd = (fp.J_d - fm.J_d) / (2 * h);
    Eigen::Vector2d rdd;
    const Eigen::Matrix<double, 2, 6> an =
        pixelFactorJacobianDepthDerivative(transferPoint(R, t, K, x, y, d), t, K.fx, K.fy, d, &rdd);
    EXPECT_LE((an - fd).norm(), 1e-6 * (1 + fd.norm())) << "trial " << trial;
    EXPECT_LE((rdd - fd_rdd).norm(), 1e-6 * (1 + fd_rdd.norm())) << "trial " << trial;
  }
}

sim::ScenarioConfig scene(std::uint64_t seed, int H, int W, double weight_scale) {
  sim::ScenarioConfig c;
  c.camera.H = H;
  c.camera.W = W;
  c.trajectory.num_keyframes = 6;
  c.mode = sim::SimulationMode::WholeTrajectory;
  c.weight_scale = weight_scale;
  c.seed = seed;
  return c;
}

/// M, N and the bias score summed factor by factor over the whole tangent: every factor's rows
/// [J_i | J_j] placed in its slots by linearizePixelFactor, their depth derivatives by central
/// differences of it, P⊥ as a dense projector over the depth's factors. Stereo factors (the
/// fixed rig) are rows with no pose part, RGB-D readings rows with J_d = −1 and no curvature:
/// both only through the depth's information and (stereo) its second-order estimate. The fourth
/// cumulants: each flow row's (γ₂ / λ²) and the two axes' of one factor jointly (γ_xy / λ_x λ_y),
/// from the general sums Σ cum(f, g, h, l) α_f α_g β_h β_lᵀ over all rows of a depth. Returns
/// {γ₂, γ_xy}.
std::pair<double, double> expectTermsMatchDenseReference(const Snapshot& s, const DbaOptions& o) {
  const DbaNormalEquations ne = linearizeDba(s, o, true);
  const int n = static_cast<int>(ne.keyframes.size());
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(6 * n, 6 * n), N = M, Mk = M, Nk = M, Mx = M, Nx = M;
  Eigen::VectorXd bias = Eigen::VectorXd::Zero(6 * n);
  std::size_t depths = 0;
  // Per edge: rows, Σ z², Σ z⁴ of the standardized residuals (the kurtosis' estimate); factors
  // with both axes, Σ z_x² z_y², Σ z_x z_y (the joint cumulant's).
  std::vector<std::array<double, 6>> moments(s.numEdges(), {0.0, 0.0, 0.0, 0.0, 0.0, 0.0});
  int stereo_rows = 0, sensor_rows = 0;
  const std::size_t HW = s.pixelsPerFrame();
  for (int src : s.graphKeyframes()) {
    for (std::size_t p = 0; p < HW; ++p) {
      const double d = s.disps[src * HW + p], x = static_cast<double>(p % s.W),
                   y = static_cast<double>(p / s.W);
      std::vector<Eigen::RowVectorXd> J, Jp;
      std::vector<double> Jd, rdd, lam, res;
      std::vector<int> edge_of;  // -1: an RGB-D reading (no κ term)
      std::vector<int> axis_of;  // the row's axis (0, 1)
      bool pose_factor = false;
      for (int e = 0; e < s.numEdges(); ++e) {
        if (s.ii[e] != src) continue;
        const bool st = s.jj[e] == src;
        const Eigen::Isometry3d T_ji = st ? s.stereoRig() : s.T_cw(s.jj[e]) * s.T_cw(src).inverse();
        const auto lin = [&](double dd) {
          PixelFactorLinearization f;
          linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, x, y, dd, 0.0, 0.0, &f);
          return f;
        };
        const Eigen::Vector3d Y = transferPoint(T_ji.linear(), T_ji.translation(), K, x, y, d);
        if (!keepPixelFactor(o, d, Y.z())) continue;
        const double step = 1e-6 * std::max(1.0, std::abs(d));
        const PixelFactorLinearization f = lin(d), fp = lin(d + step), fm = lin(d - step);
        PixelFactorLinearization fr;  // with the targets: the residual
        linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, x, y, d, s.targetPlane(e, 0)[p],
                             s.targetPlane(e, 1)[p], &fr);
        const int a = ne.slot_of[s.ii[e]], b = ne.slot_of[s.jj[e]];
        for (int c = 0; c < 2; ++c) {
          const double l = o.weight_scale * s.weightPlane(e, c)[p];
          if (!(l > 0)) continue;
          Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(6 * n), drow = row;
          if (!st) {
            row.segment<6>(6 * a) = f.J_i.row(c);
            row.segment<6>(6 * b) = f.J_j.row(c);
            drow.segment<6>(6 * a) = (fp.J_i.row(c) - fm.J_i.row(c)) / (2 * step);
            drow.segment<6>(6 * b) = (fp.J_j.row(c) - fm.J_j.row(c)) / (2 * step);
            pose_factor = true;
          } else {
            ++stereo_rows;
          }
          J.push_back(row);
          Jp.push_back(drow);
          Jd.push_back(f.J_d[c]);
          rdd.push_back((fp.J_d[c] - fm.J_d[c]) / (2 * step));
          lam.push_back(l);
          res.push_back(fr.r[c]);
          edge_of.push_back(e);
          axis_of.push_back(c);
        }
      }
      if (s.disps_sens && o.sensor_depth_weight > 0 && (*s.disps_sens)[src * HW + p] > 0 && d > 0) {
        J.push_back(Eigen::RowVectorXd::Zero(6 * n));
        Jp.push_back(Eigen::RowVectorXd::Zero(6 * n));
        Jd.push_back(-1.0);
        rdd.push_back(0.0);
        lam.push_back(o.sensor_depth_weight);
        res.push_back(0.0);
        edge_of.push_back(-1);
        axis_of.push_back(0);
        ++sensor_rows;
      }
      const int m = static_cast<int>(J.size());
      if (m == 0 || !pose_factor) continue;
      Eigen::MatrixXd A(m, 6 * n), Ap(m, 6 * n);
      Eigen::VectorXd jd(m), r2(m), w(m);
      for (int r = 0; r < m; ++r) {
        A.row(r) = J[r];
        Ap.row(r) = Jp[r];
        jd[r] = Jd[r];
        r2[r] = rdd[r];
        w[r] = lam[r];
      }
      const double h = jd.dot(w.asDiagonal() * jd);
      if (!(h > o.depth_info_eps)) continue;
      ++depths;
      const Eigen::MatrixXd W = w.asDiagonal();
      const Eigen::MatrixXd WP = W - W * jd * jd.transpose() * W / h;  // W P⊥
      M += Ap.transpose() * WP * Ap / h;
      const Eigen::VectorXd g = A.transpose() * WP * r2;
      N += g * g.transpose() / (2 * h * h);
      bias -= g / (2 * h);
      // Fourth cumulants (per flow row γ₂/λ_f², and the two axes of one factor jointly
      // γ_xy/(λ_x λ_y)): Var(δ·J'ᵀWP⊥ε) gains Σ cum α α β βᵀ and Var(½δ²) gains ¼ Σ cum α⁴,
      // with δ = Σ α_f ε_f and J'ᵀWP⊥ε = Σ β_f ε_f.
      const Eigen::VectorXd a = Ap.transpose() * (w.cwiseProduct(jd));
      // The general sums over every (f, g, h, l) of the depth's rows with the cumulant per unit
      // γ₂ (f = g = h = l, a flow row) and per unit γ_xy (two and two of the x and y rows of
      // one factor, in any order; odd counts have none).
      std::vector<double> alpha(m), z(m, 0.0);
      std::vector<Eigen::VectorXd> beta(m);
      for (int r = 0; r < m; ++r) {
        alpha[r] = w[r] * jd[r] / h;
        beta[r] = w[r] * Ap.row(r).transpose() - a * alpha[r];
        const double lev = w[r] * jd[r] * jd[r] / h;
        if (edge_of[r] >= 0 && lev < 0.999) z[r] = std::sqrt(w[r] / (1 - lev)) * res[r];
      }
      const auto same_factor = [&](int f, int f2) {
        return edge_of[f] >= 0 && edge_of[f] == edge_of[f2] &&
               (f == f2 || f == f2 + 1 || f2 == f + 1) && (f == f2 || axis_of[f] != axis_of[f2]);
      };
      const auto cum = [&](int f, int f2, int hh, int l, bool cross) {
        const int idx[4] = {f, f2, hh, l};
        for (int i = 1; i < 4; ++i)
          if (!same_factor(f, idx[i])) return 0.0;
        int nx = 0;
        for (int i : idx) nx += axis_of[i] == 0;
        if (!cross)
          return nx == 0 || nx == 4 ? (f == f2 && f2 == hh && hh == l ? 1.0 / (w[f] * w[f]) : 0.0)
                                    : 0.0;
        if (nx != 2) return 0.0;
        double lx = 0, ly = 0;
        for (int i : idx) (axis_of[i] == 0 ? lx : ly) = w[i];
        return 1.0 / (lx * ly);
      };
      double q4 = 0, q4x = 0;
      for (int f = 0; f < m; ++f)
        for (int gg = 0; gg < m; ++gg)
          for (int hh = 0; hh < m; ++hh)
            for (int l = 0; l < m; ++l) {
              const double ck = cum(f, gg, hh, l, false), cx = cum(f, gg, hh, l, true);
              if (ck == 0 && cx == 0) continue;
              const Eigen::MatrixXd bb = alpha[f] * alpha[gg] * beta[hh] * beta[l].transpose();
              const double aaaa = alpha[f] * alpha[gg] * alpha[hh] * alpha[l];
              Mk += ck * bb;
              Mx += cx * bb;
              q4 += ck * aaaa;
              q4x += cx * aaaa;
            }
      for (int r = 0; r < m; ++r) {
        if (z[r] == 0) continue;
        auto& mo = moments[edge_of[r]];
        mo[0] += 1;
        mo[1] += z[r] * z[r];
        mo[2] += std::pow(z[r], 4);
        if (r + 1 < m && edge_of[r + 1] == edge_of[r] && axis_of[r] == 0 && axis_of[r + 1] == 1 &&
            z[r + 1] != 0) {
          mo[3] += 1;
          mo[4] += z[r] * z[r] * z[r + 1] * z[r + 1];
          mo[5] += z[r] * z[r + 1];
        }
      }
      Nk += 0.25 * q4 * g * g.transpose();
      Nx += 0.25 * q4x * g * g.transpose();
    }
  }
  double rows = 0, ratio = 0, pairs = 0, joint = 0;
  for (const auto& mo : moments) {
    if (mo[0] < 8 || !(mo[1] > 0)) continue;
    const double m2 = mo[1] / mo[0];
    ratio += mo[0] * (mo[2] / mo[0]) / (m2 * m2);
    rows += mo[0];
    if (mo[3] < 8) continue;
    const double rho = mo[5] / mo[3] / m2;
    joint += mo[3] * (mo[4] / mo[3] / (m2 * m2) - 1 - 2 * rho * rho);
    pairs += mo[3];
  }
  const double kurtosis = std::max(0.0, ratio / rows - 3.0);
  const double cross = pairs > 0 ? std::clamp(joint / pairs, 0.0, kurtosis) : 0.0;
  const Eigen::MatrixXd MK = kurtosis * Mk + cross * Mx, NK = kurtosis * Nk + cross * Nx;
  EXPECT_GT(M.norm(), 0);
  EXPECT_GT(Mk.norm(), 0);
  EXPECT_GT(Mx.norm(), 0);
  if (s.stereo_rig) {
    EXPECT_GT(stereo_rows, 0) << "the snapshot has no stereo factor";
  }
  if (s.disps_sens) {
    EXPECT_GT(sensor_rows, 0) << "the snapshot has no sensor depth";
  }
  // The sums over the depths run in the kernel's dot products: every variant this CPU runs.
  testing::forEachKernelIsa([&](kernel::Isa) {
    const DepthNoiseTerms dn = depthNoiseTerms(s, o, ne);
    EXPECT_EQ(dn.depths, depths);
    EXPECT_LE((dn.M - M).norm(), 1e-6 * M.norm());
    EXPECT_LE((dn.N - N).norm(), 1e-6 * N.norm() + 1e-12 * M.norm());
    EXPECT_LE((dn.bias_score - bias).norm(), 1e-6 * bias.norm() + 1e-12);
    EXPECT_LE((dn.M_kurtosis - MK).norm(), 1e-6 * MK.norm());
    EXPECT_LE((dn.N_kurtosis - NK).norm(), 1e-6 * NK.norm() + 1e-12 * MK.norm());
    EXPECT_NEAR(dn.kurtosis, kurtosis, 1e-9 * (1 + kurtosis));
    EXPECT_NEAR(dn.cross_kurtosis, cross, 1e-9 * (1 + cross));
    // Without the fourth cumulants: the Gaussian terms to the bit, the estimates reported.
    const DepthNoiseTerms g0 = depthNoiseTerms(s, o, ne, false);
    EXPECT_TRUE(g0.M == dn.M && g0.N == dn.N && g0.bias_score == dn.bias_score);
    EXPECT_EQ(g0.M_kurtosis.norm(), 0.0);
    EXPECT_EQ(g0.N_kurtosis.norm(), 0.0);
    EXPECT_EQ(g0.kurtosis, dn.kurtosis);
    EXPECT_EQ(g0.cross_kurtosis, dn.cross_kurtosis);
    // Scale-free: every weight × 4 leaves M and N as they are (the covariance's share grows
    // with the noise variance only through S⁻¹).
    DbaOptions o4 = o;
    o4.weight_scale *= 4;
    o4.sensor_depth_weight *= 4;
    const DepthNoiseTerms dn4 = depthNoiseTerms(s, o4, linearizeDba(s, o4, true));
    EXPECT_LE((dn4.M - dn.M).norm(), 1e-9 * dn.M.norm());
    EXPECT_LE((dn4.N - dn.N).norm(), 1e-9 * dn.M.norm());
    EXPECT_LE((dn4.M_kurtosis - dn.M_kurtosis).norm(), 1e-9 * dn.M_kurtosis.norm());
    EXPECT_NEAR(dn4.kurtosis, dn.kurtosis, 1e-9 * (1 + dn.kurtosis));
    EXPECT_NEAR(dn4.cross_kurtosis, dn.cross_kurtosis, 1e-9 * (1 + dn.cross_kurtosis));
  });
  return {kurtosis, cross};
}

TEST(DepthNoise, TermsMatchDenseReference) {
  // Heavy-tailed targets (5 % of the pixels at 10×), so that the kurtosis is not clamped to 0.
  sim::ScenarioConfig cfg0 = scene(5, 12, 16, 100.0);
  cfg0.noise.outlier_fraction = 0.05;
  const sim::Scenario sc(cfg0);
  const Snapshot mono = sc.simulate(0, 3).snapshot;
  const DbaOptions o = sc.config().engineOptions();
  {
    SCOPED_TRACE("mono");
    // The simulator's outliers scale both axes of a pixel's flow together: a scale mixture,
    // whose joint cumulant is a third of each axis' (γ_xy = γ₂ / 3 for the errors; the
    // residuals, which the depths absorb part of, give less: 0.23 here, 0.32–0.37 on the
    // study's scene). The estimate must see it.
    const auto [g2, gxy] = expectTermsMatchDenseReference(mono, o);
    EXPECT_GT(g2, 1.0) << "the targets are not heavy-tailed";
    EXPECT_GT(gxy, 0.15 * g2) << "γ₂ " << g2 << ", γ_xy " << gxy;
    EXPECT_LT(gxy, 0.5 * g2) << "γ₂ " << g2 << ", γ_xy " << gxy;
  }
  {
    // Stereo factors' curvature enters the depth's second-order estimate (N, the bias); a
    // version that left them out fails here. A rectified rig (a pure x baseline) keeps Y.z
    // fixed, so its factors are linear in the inverse depth: the rig here is not rectified.
    SCOPED_TRACE("stereo");
    Snapshot st = mono;
    sim::StereoConfig cfg;
    cfg.T_rig = Eigen::Translation3d(-0.1, 0.01, 0.04) *
                Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.2, 1.0, 0.1).normalized());
    cfg.weight_scale = o.weight_scale;
    sim::addStereoEdges(st, cfg);
    st.validate();
    expectTermsMatchDenseReference(st, o);
  }
  {
    SCOPED_TRACE("rgbd");
    Snapshot rgbd = mono;
    sim::RgbdConfig rc;
    sim::addSensorDepth(rgbd, rc);
    rgbd.validate();
    DbaOptions orgbd = o;
    orgbd.sensor_depth_weight = rc.alpha;
    expectTermsMatchDenseReference(rgbd, orgbd);
  }
}

/// The free keyframes' joint covariance (6 per free keyframe, in graph order) from the query
/// API's 12 × 12 joints; the gauge must fix whole keyframes (else the reduced coordinates are not
/// a selection of the tangent).
Eigen::MatrixXd freeJoint(const DbaCovariance& c, std::vector<int>* free) {
  free->clear();
  for (int k : c.keyframes()) {
    const int dof = c.freeDof(k);
    EXPECT_TRUE(dof == 0 || dof == 6) << "keyframe " << k << " has " << dof << " free DoF";
    if (dof == 6) free->push_back(k);
  }
  const int n = static_cast<int>(free->size());
  Eigen::MatrixXd J(6 * n, 6 * n);
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) {
      if (a == b) {
        J.block<6, 6>(6 * a, 6 * a) = c.marginal((*free)[a]);
        continue;
      }
      const Matrix12d ab = c.joint((*free)[a], (*free)[b]);
      J.block<6, 6>(6 * a, 6 * b) = ab.topRightCorner<6, 6>();
      J.block<6, 6>(6 * b, 6 * a) = ab.bottomLeftCorner<6, 6>();
    }
  return J;
}

/// The wiring through selfCalibratedCovariance: the covariance with the term minus the one
/// without is Σ₁ + Σ₁(M + N)Σ₁ − Σ_w, written here from
/// its definition on the white-inflated snapshot: Σ_w its joint covariance from the sparse query
/// API, Σ₁ = (Σ_w⁻¹ − M)⁻¹, M and N (and their κ terms, at the estimated γ₂ and γ_xy) from
/// depthNoiseTerms (checked above) on the free keyframes.
TEST(DepthNoise, CalibratedCovarianceAddsTheTerm) {
  sim::ScenarioConfig cfg = scene(8, 24, 32, 100.0);
  cfg.noise.outlier_fraction = 0.02;  // heavy tails: the κ share is not 0
  const sim::Scenario sc(cfg);
  const sim::SimulatedSnapshot sim = sc.simulate(0, 4);
  const Snapshot& s = sim.snapshot;
  const DbaOptions o = sc.config().engineOptions();
  {
    const SelfCalibrationOptions c;
    ASSERT_TRUE(c.depth_noise) << "the term is the default";
    const SelfCalibration with = selfCalibrate(s, o, c);
    SelfCalibration without = with;
    without.depth_noise = false;
    const Snapshot si = inflateWeights(s, with.inflations());
    std::vector<int> free, free_w;
    const Eigen::MatrixXd Sw = freeJoint(DbaCovariance(si, o), &free_w);
    const DbaNormalEquations ne = linearizeDba(si, o, true);
    const DepthNoiseTerms dn = depthNoiseTerms(si, o, ne);
    const int n = static_cast<int>(free_w.size());
    // A 6n × 6n term of depthNoiseTerms (slots of ne.keyframes) on the free keyframes.
    const auto onFree = [&](const Eigen::MatrixXd& X) {
      Eigen::MatrixXd F(6 * n, 6 * n);
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b)
          F.block<6, 6>(6 * a, 6 * b) =
              X.block<6, 6>(6 * ne.slot_of[free_w[a]], 6 * ne.slot_of[free_w[b]]);
      return F;
    };
    const Eigen::MatrixXd Mf = onFree(dn.M), Nf = onFree(dn.N), Mkf = onFree(dn.M_kurtosis),
                          Nkf = onFree(dn.N_kurtosis);
    ASSERT_GT(dn.kurtosis, 1.0) << "the targets are not heavy-tailed";
    // H = S − M keeps the Gaussian M; the variance M + N gains the κ terms.
    const Eigen::MatrixXd S1 = (Eigen::MatrixXd(Sw.inverse()) - Mf).inverse();
    ASSERT_GT(dn.cross_kurtosis, 1.0) << "the outliers are not joint across the axes";
    const Eigen::MatrixXd term = S1 + S1 * (Mf + Nf + Mkf + Nkf) * S1 - Sw;
    ASSERT_GT(term.trace(), 0.05 * Sw.trace()) << "the scene does not test the term";
    const DbaCovariance cw = selfCalibratedCovariance(s, o, {}, with);
    const Eigen::MatrixXd own = freeJoint(selfCalibratedCovariance(s, o, {}, without), &free);
    const Eigen::MatrixXd got = freeJoint(cw, &free) - own;
    ASSERT_EQ(free, free_w);
    EXPECT_LE((got - term).norm(), 1e-6 * term.norm());
    // What the summaries report: the term's trace over the model's own, and the γ₂ used.
    EXPECT_NEAR(cw.summary().self_calibration.depth_noise_share, term.trace() / own.trace(),
                1e-6 * term.trace() / own.trace());
    EXPECT_EQ(cw.summary().self_calibration.depth_noise_kurtosis, dn.kurtosis);
    EXPECT_EQ(cw.summary().self_calibration.depth_noise_cross_kurtosis, dn.cross_kurtosis);
    // Without the κ share: the Gaussian term alone.
    SelfCalibration gaussian = with;
    gaussian.depth_noise_kurtosis = false;
    const Eigen::MatrixXd term0 = S1 + S1 * (Mf + Nf) * S1 - Sw;
    EXPECT_LE((freeJoint(selfCalibratedCovariance(s, o, {}, gaussian), &free) - own - term0).norm(),
              1e-6 * term0.norm());
    EXPECT_GT(term.trace(), term0.trace());
  }
}

/// 40 runs of snapshot 0 of `sc` (noise seeds first_seed, first_seed + 1, ...), each evaluated
/// with the self-calibrations a and b (nullptr: the raw covariance): the absolute samples'
/// statistics of each, printed under their names.
std::pair<ConsistencyStats, ConsistencyStats> monteCarloPair(
    const sim::Scenario& sc, std::uint64_t first_seed, const char* name_a,
    const SelfCalibrationOptions* a, const char* name_b, const SelfCalibrationOptions* b,
    const DbaOptions* options = nullptr) {
  const DbaOptions o = options ? *options : sc.config().engineOptions();
  sim::EvaluationSamples sa, sb;
  const int runs = 40;
  for (int run = 0; run < runs; ++run) {
    const sim::SimulatedSnapshot snap = sc.simulate(0, first_seed + run);
    sa.append(sim::evaluateSnapshot(snap, o, run, sim::PairSelection::Consecutive, a));
    sb.append(sim::evaluateSnapshot(snap, o, run, sim::PairSelection::Consecutive, b));
  }
  const ConsistencyStats x = summarize(sa.absolute), y = summarize(sb.absolute);
  for (const auto& [name, st] : {std::pair(name_a, x), std::pair(name_b, y)})
    std::printf("%-18s ANEES %.3f [%.3f, %.3f], 1 sigma %.3f, tail %.3f\n", name, st.anees,
                st.region.lower, st.region.upper, st.coverage_all[0], st.tail_95);
  return {x, y};
}

/// The claim, by Monte Carlo on runs no formula was fitted to: white noise 3x the claimed at
/// weight scale 100 on a 24 x 32 grid, where the depths are poorly determined. The calibration
/// finds the scale; without the depth-noise term the covariance is still over-confident (the
/// linearization misses the depths' error), with it the ANEES is inside its 95 % region.
TEST(SelfCalibrationMonteCarlo, DepthNoiseTermMakesStrongWhiteNoiseConsistent) {
  sim::ScenarioConfig cfg = scene(21, 24, 32, 100.0);
  cfg.noise.amplitude = 3.0;
  const sim::Scenario sc(cfg);
  SelfCalibrationOptions with, without;
  with.depth_noise = true;
  without.depth_noise = false;
  const auto [sa, sb] = monteCarloPair(sc, 100, "with the term:", &with, "without:", &without);
  EXPECT_GT(sb.anees, sb.region.upper) << "the scene does not test the term";
  EXPECT_TRUE(sa.inside) << sa.anees << " outside [" << sa.region.lower << ", " << sa.region.upper
                         << "]";
}

/// White noise as the confidences claim it, on the scene of the self-calibration's tests: the
/// term, on by default, must not make the covariance too wide where nothing is wrong but the
/// linearization. These runs: raw ANEES 6.51, with the term 5.64, 1σ 71.5 %, tail 1.3 % (runs
/// 100-159 of this seed: raw 7.18, above its region [5.16, 6.91], with the term 6.24).
TEST(SelfCalibrationMonteCarlo, DepthNoiseTermKeepsMatchingWhiteNoiseConsistent) {
  const sim::Scenario sc(scene(21, 24, 32, 100.0));
  const SelfCalibrationOptions c;
  const auto [sa, sr] = monteCarloPair(sc, 300, "with the term:", &c, "raw:", nullptr);
  EXPECT_TRUE(sa.inside) << sa.anees << " outside [" << sa.region.lower << ", " << sa.region.upper
                         << "]";
  EXPECT_LT(sa.anees, sr.anees) << "the term must widen the covariance";
}

/// Heavy tails (2 % of the pixels at 10×) on the same scene: the residuals' energy grows 3×,
/// the poses' error far more (an outlier's depth goes wrong with it and moves the poses'
/// Jacobians). The Gaussian depth term leaves vce far above its region (ANEES 14.4). The
/// fourth-cumulant share with each row's cumulant alone took it to 9.6, still outside; with the
/// two flow axes' joint cumulant too (an outlier moves both components of a pixel's flow), 7.04,
/// inside (on the study's held-out runs nuisance 10.2 -> 7.0 -> 5.9).
TEST(SelfCalibrationMonteCarlo, DepthNoiseKurtosisMakesOutliersConsistent) {
  sim::ScenarioConfig cfg = scene(21, 24, 32, 100.0);
  cfg.noise.outlier_fraction = 0.02;
  cfg.noise.outlier_factor = 10.0;
  const sim::Scenario sc(cfg);
  SelfCalibrationOptions with, gaussian;
  gaussian.depth_noise_kurtosis = false;
  const auto [sa, sb] =
      monteCarloPair(sc, 500, "with the kurtosis:", &with, "Gaussian term:", &gaussian);
  EXPECT_GT(sb.anees, sb.region.upper) << "the scene does not test the kurtosis";
  EXPECT_LT(sa.anees, 0.75 * sb.anees) << "the kurtosis share removes less than a quarter";
  EXPECT_GT(sa.anees, sa.region.lower) << "the kurtosis share overshoots";
  EXPECT_LT(sa.anees, sa.region.upper) << "without the axes' joint cumulant this was 9.6";
}

/// DROID's other modes with the factors on the depths alone mis-claimed too: stereo targets (and
/// flow) with 2x the claimed σ, RGB-D readings whose α is claimed 4x too high; one held pose
/// (metric scale). Each stereo edge and the readings get a variance component of their own, the
/// default then inside its region. Before they had one (stereo edges and readings at factor 1,
/// the flow's edges corrected) the study's held-out runs gave 8.11 and 8.71, above [4.58, 7.61]
/// (docs/studies/droid-modes.md); on these runs stereo 8.93 and RGB-D 9.25 (this test's code on the
/// earlier engine), now 6.49 and 5.98.
TEST(SelfCalibrationMonteCarlo, DepthOnlyFactorsOwnScalesMakeStereoAndRgbdConsistent) {
  for (const sim::SensorMode mode : {sim::SensorMode::Stereo, sim::SensorMode::Rgbd}) {
    SCOPED_TRACE(toString(mode));
    sim::ScenarioConfig cfg = scene(23, 24, 32, 100.0);
    cfg.sensor.mode = mode;
    cfg.gauge.type = GaugeOptions::Type::Droid;
    if (mode == sim::SensorMode::Stereo) cfg.noise.amplitude = 2.0;
    const sim::Scenario sc(cfg);
    DbaOptions o = cfg.engineOptions();
    if (mode == sim::SensorMode::Rgbd) o.sensor_depth_weight *= 4.0;
    // The components themselves, on one snapshot: variance 4x the claimed. (The state is the
    // optimum at the true α, the scenario's solve, not at the claimed one.)
    const SelfCalibrationOptions c;  // the default
    const Snapshot snap = sc.simulate(0, 700).snapshot;
    const SelfCalibration cal = selfCalibrate(snap, o, c);
    if (mode == sim::SensorMode::Stereo) {
      std::vector<double> v;
      for (const EdgeCalibration& e : cal.edges)
        if (e.i == e.j) v.push_back(e.inflation);
      ASSERT_FALSE(v.empty());
      std::sort(v.begin(), v.end());
      EXPECT_NEAR(v[v.size() / 2], 4.0, 0.6) << "stereo edges' median inflation";
    } else {
      // One pass: the state is not the optimum at the claimed α, whose non-zero gradient adds
      // to the readings' residuals (runs 700-719: mean 4.5, 4.27 to 4.76; at the optimum of
      // the claimed α, where one pass is pulled towards 1 by the flow rows sharing the depths,
      // 3.38 to 3.76 on runs 700-709).
      EXPECT_GT(cal.sensor_depth_scale, 3.5);
      EXPECT_LT(cal.sensor_depth_scale, 5.2);
    }
    const auto [sa, sr] = monteCarloPair(sc, 700, "default:", &c, "raw:", nullptr, &o);
    EXPECT_GT(sr.anees, sr.region.upper) << "the scene does not test the components";
    EXPECT_TRUE(sa.inside) << sa.anees << " outside [" << sa.region.lower << ", " << sa.region.upper
                           << "]";
  }
}

}  // namespace
}  // namespace dbacov
