// The depths' second-order noise term (depth_noise.h): its Jacobian derivatives against finite
// differences, its sums against a dense reference built factor by factor with finite-difference
// derivatives (no Γ, no adjoint, no edge coordinates), and its claim by Monte Carlo.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <Eigen/Dense>

#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_factor.h"
#include "dbacov/core/depth_noise.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/sim/consistency.h"
#include "dbacov/sim/monte_carlo.h"
#include "dbacov/sim/scenario.h"

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
/// differences of it, P⊥ as a dense projector over the depth's factors.
TEST(DepthNoise, TermsMatchDenseReference) {
  const sim::Scenario sc(scene(5, 12, 16, 100.0));
  const sim::SimulatedSnapshot sim = sc.simulate(0, 3);
  const Snapshot& s = sim.snapshot;
  const DbaOptions o = sc.config().engineOptions();
  const DbaNormalEquations ne = linearizeDba(s, o, true);
  const DepthNoiseTerms dn = depthNoiseTerms(s, o, ne);
  const int n = static_cast<int>(ne.keyframes.size());
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(6 * n, 6 * n), N = M;
  Eigen::VectorXd bias = Eigen::VectorXd::Zero(6 * n);
  std::size_t depths = 0;
  const std::size_t HW = s.pixelsPerFrame();
  for (int src : s.graphKeyframes()) {
    for (std::size_t p = 0; p < HW; ++p) {
      const double d = s.disps[src * HW + p], x = static_cast<double>(p % s.W),
                   y = static_cast<double>(p / s.W);
      std::vector<Eigen::RowVectorXd> J, Jp;
      std::vector<double> Jd, rdd, lam;
      for (int e = 0; e < s.numEdges(); ++e) {
        if (s.ii[e] != src || s.jj[e] == src) continue;
        const Eigen::Isometry3d T_ji = s.T_cw(s.jj[e]) * s.T_cw(src).inverse();
        const auto lin = [&](double dd) {
          PixelFactorLinearization f;
          linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, x, y, dd, 0.0, 0.0, &f);
          return f;
        };
        const Eigen::Vector3d Y = transferPoint(T_ji.linear(), T_ji.translation(), K, x, y, d);
        if (!keepPixelFactor(o, d, Y.z())) continue;
        const double step = 1e-6 * std::max(1.0, std::abs(d));
        const PixelFactorLinearization f = lin(d), fp = lin(d + step), fm = lin(d - step);
        const int a = ne.slot_of[s.ii[e]], b = ne.slot_of[s.jj[e]];
        for (int c = 0; c < 2; ++c) {
          const double l = o.weight_scale * s.weightPlane(e, c)[p];
          if (!(l > 0)) continue;
          Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(6 * n), drow = row;
          row.segment<6>(6 * a) = f.J_i.row(c);
          row.segment<6>(6 * b) = f.J_j.row(c);
          drow.segment<6>(6 * a) = (fp.J_i.row(c) - fm.J_i.row(c)) / (2 * step);
          drow.segment<6>(6 * b) = (fp.J_j.row(c) - fm.J_j.row(c)) / (2 * step);
          J.push_back(row);
          Jp.push_back(drow);
          Jd.push_back(f.J_d[c]);
          rdd.push_back((fp.J_d[c] - fm.J_d[c]) / (2 * step));
          lam.push_back(l);
        }
      }
      const int m = static_cast<int>(J.size());
      if (m == 0) continue;
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
    }
  }
  EXPECT_EQ(dn.depths, depths);
  ASSERT_GT(M.norm(), 0);
  EXPECT_LE((dn.M - M).norm(), 1e-6 * M.norm());
  EXPECT_LE((dn.N - N).norm(), 1e-6 * N.norm() + 1e-12 * M.norm());
  EXPECT_LE((dn.bias_score - bias).norm(), 1e-6 * bias.norm() + 1e-12);
  // Scale-free: every weight × 4 leaves M and N as they are (the covariance's share grows with
  // the noise variance only through S⁻¹).
  DbaOptions o4 = o;
  o4.weight_scale *= 4;
  const DepthNoiseTerms dn4 = depthNoiseTerms(s, o4, linearizeDba(s, o4, true));
  EXPECT_LE((dn4.M - dn.M).norm(), 1e-9 * dn.M.norm());
  EXPECT_LE((dn4.N - dn.N).norm(), 1e-9 * dn.M.norm());
}

/// The claim, by Monte Carlo on runs no formula was fitted to: white noise 3x the claimed at
/// weight scale 100 on a 24 x 32 grid, where the depths are poorly determined. vce finds the
/// scale; without the depth-noise term the covariance is still over-confident (the linearization
/// misses the depths' error), with it the ANEES is inside its 95 % region.
TEST(SelfCalibrationMonteCarlo, DepthNoiseTermMakesStrongWhiteNoiseConsistent) {
  sim::ScenarioConfig cfg = scene(21, 24, 32, 100.0);
  cfg.noise.amplitude = 3.0;
  const sim::Scenario sc(cfg);
  const DbaOptions o = sc.config().engineOptions();
  SelfCalibrationOptions with, without;
  with.method = without.method = SelfCalibrationMethod::Vce;
  with.depth_noise = true;
  without.depth_noise = false;
  sim::EvaluationSamples a, b;
  const int runs = 40;
  for (int run = 0; run < runs; ++run) {
    const sim::SimulatedSnapshot snap = sc.simulate(0, 100 + run);
    a.append(sim::evaluateSnapshot(snap, o, run, sim::PairSelection::Consecutive, &with));
    b.append(sim::evaluateSnapshot(snap, o, run, sim::PairSelection::Consecutive, &without));
  }
  const ConsistencyStats sa = summarize(a.absolute), sb = summarize(b.absolute);
  std::printf("with the term: ANEES %.3f [%.3f, %.3f], 1 sigma %.3f, tail %.3f\n", sa.anees,
              sa.region.lower, sa.region.upper, sa.coverage_all[0], sa.tail_95);
  std::printf("without:       ANEES %.3f, 1 sigma %.3f, tail %.3f\n", sb.anees, sb.coverage_all[0],
              sb.tail_95);
  EXPECT_GT(sb.anees, sb.region.upper) << "the scene does not test the term";
  EXPECT_TRUE(sa.inside) << sa.anees << " outside [" << sa.region.lower << ", " << sa.region.upper
                         << "]";
}

}  // namespace
}  // namespace dbacov
