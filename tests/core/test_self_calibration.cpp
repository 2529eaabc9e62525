// Self-calibration (self_calibration.h): per-edge redundancies and the nuisance model against a
// dense reference built from every factor row, and the statistical claims on solved snapshots.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <random>
#include <string>

#include <Eigen/Dense>

#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_factor.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/gauge.h"
#include "dbacov/core/given_model.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/nuisance_basis.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/self_calibration_fit.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/sensor_modes.h"
#include "fixtures.h"
#include "kernel_variants.h"

namespace dbacov {
namespace {

/// A small scenario solved to the optimum of its own measurements.
sim::ScenarioConfig smallScenario(std::uint64_t seed, int H, int W) {
  sim::ScenarioConfig c;
  c.camera.H = H;
  c.camera.W = W;
  c.trajectory.num_keyframes = 6;
  c.mode = sim::SimulationMode::WholeTrajectory;
  c.weight_scale = 100.0;
  c.seed = seed;
  return c;
}

/// Dense reference of the per-edge quantities: whitened rows over (poses, depths), hat matrix,
/// depth-reduced pose columns Ṽ = (I − H_d) A_p.
struct EdgeReference {
  // Per cluster: the edges e < E, then each keyframe k's sensor readings (RGB-D) as E + k.
  std::vector<double> redundancy;
  std::vector<int> rows;
  std::vector<Eigen::VectorXd> g;  // full tangent, 6n
  Eigen::MatrixXd Sigma;           // 6n × 6n
  // For the nuisance method: whitened rows' depth-reduced pose columns V (rows × 6n), the
  // field's whitened columns Φ (rows × mE: m = field_coords per edge, [1, u, v] and the tents per
  // channel), the residual energy q_e, the joint field information Φᵀ P⊥ Φ (mE × mE) and the
  // field scores Φᵀ P⊥ r.
  Eigen::MatrixXd V, Phi, Mfield;
  int field_coords = 0;
  Eigen::VectorXd tfield;
  std::vector<double> q;
  std::vector<int> source;    // per cluster
  std::vector<int> row_edge;  // per row, its cluster
};

EdgeReference denseEdgeReference(const Snapshot& s, const DbaOptions& o, int nodes = 0) {
  const std::vector<int> kf = s.graphKeyframes();
  const int n = static_cast<int>(kf.size()), HW = static_cast<int>(s.pixelsPerFrame());
  std::vector<int> slot(s.numKeyframes(), -1);
  for (int a = 0; a < n; ++a) slot[kf[a]] = a;
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  struct Row {
    int edge, si, sj, depth, channel, x, y;
    Eigen::Matrix<double, 1, 6> Ji, Jj;
    double Jd, r, sl;
  };
  std::vector<Row> rows;
  std::vector<int> depth_of(static_cast<std::size_t>(s.numKeyframes()) * HW, -1);
  int D = 0;
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    // A stereo edge (i == j): the fixed rig, no pose Jacobian (a factor on the depth alone).
    const bool stereo = i == j;
    const Eigen::Isometry3d T_ji = stereo ? s.stereoRig() : s.T_cw(j) * s.T_wc(i);
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(i) * HW + p];
      if (!(d > 0)) continue;
      const Eigen::Vector3d Y =
          transferPoint(T_ji.linear(), T_ji.translation(), K, p % s.W, p / s.W, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      PixelFactorLinearization f;
      linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, p % s.W, p / s.W, d,
                           s.targetPlane(e, 0)[p], s.targetPlane(e, 1)[p], &f);
      for (int c = 0; c < 2; ++c) {
        const double lam = o.weight_scale * s.weightPlane(e, c)[p];
        if (!(lam > 0)) continue;
        int& dv = depth_of[static_cast<std::size_t>(i) * HW + p];
        if (dv < 0) dv = D++;
        const double sl = std::sqrt(lam);
        const Eigen::Matrix<double, 1, 6> zero = Eigen::Matrix<double, 1, 6>::Zero();
        rows.push_back({e, slot[i], slot[j], dv, c, p % s.W, p / s.W,
                        stereo ? zero : Eigen::Matrix<double, 1, 6>(sl * f.J_i.row(c)),
                        stereo ? zero : Eigen::Matrix<double, 1, 6>(sl * f.J_j.row(c)),
                        sl * f.J_d[c], sl * f.r[c], sl});
      }
    }
  }
  // RGB-D: a source keyframe k's readings, r = d_sens − d, ∂r/∂d = −1, information α; their
  // cluster is E + k (EdgeReference).
  const int E = s.numEdges();
  if (s.disps_sens && o.sensor_depth_weight > 0)
    for (int k = 0; k < s.numKeyframes(); ++k) {
      if (std::find(s.ii.begin(), s.ii.end(), k) == s.ii.end()) continue;  // sources only
      for (int p = 0; p < HW; ++p) {
        const std::size_t at = static_cast<std::size_t>(k) * HW + p;
        const double d = s.disps[at], ds = (*s.disps_sens)[at];
        if (!(ds > 0) || !(d > 0)) continue;
        int& dv = depth_of[at];
        if (dv < 0) dv = D++;
        const double sl = std::sqrt(o.sensor_depth_weight);
        rows.push_back({E + k, slot[k], slot[k], dv, 0, p % s.W, p / s.W,
                        Eigen::Matrix<double, 1, 6>::Zero(), Eigen::Matrix<double, 1, 6>::Zero(),
                        -sl, sl * (ds - d), sl});
      }
    }
  const int M = static_cast<int>(rows.size()), P6 = 6 * n;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(M, P6 + D);
  Eigen::VectorXd r(M);
  for (int k = 0; k < M; ++k) {
    A.block<1, 6>(k, 6 * rows[k].si) += rows[k].Ji;
    A.block<1, 6>(k, 6 * rows[k].sj) += rows[k].Jj;
    A(k, P6 + rows[k].depth) = rows[k].Jd;
    r[k] = rows[k].r;
  }
  // Gauge basis of the engine (gauge.h), identity on the depths.
  const GaugeParameterization gauge = makeGauge(o.gauge, s, kf);
  const int Kp = gauge.dim();
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(P6 + D, Kp + D);
  for (int a = 0; a < n; ++a) P.block(6 * a, gauge.offset[a], 6, gauge.dimOf(a)) = gauge.basis[a];
  P.bottomRightCorner(D, D).setIdentity();
  const Eigen::MatrixXd AP = A * P;
  const Eigen::MatrixXd APC = AP * (AP.transpose() * AP).inverse();
  // Depth projection and reduced columns V = (I − H_d) A_p.
  const Eigen::MatrixXd Ad = A.rightCols(D), Ap = A.leftCols(P6);
  const Eigen::VectorXd h = Ad.colwise().squaredNorm().transpose();
  const Eigen::MatrixXd V = Ap - Ad * (h.cwiseInverse().asDiagonal() * (Ad.transpose() * Ap));
  EdgeReference ref;
  // The field's columns: [1, u, v] and, with nodes G >= 2, the G × G tents per channel, written
  // here from the tents' definition (every basis function at every pixel).
  const int mb = 3 + (nodes >= 2 ? nodes * nodes : 0), mn = 2 * mb;
  ref.field_coords = mn;
  ref.Phi = Eigen::MatrixXd::Zero(M, mn * E);
  for (int k = 0; k < M; ++k) {
    if (rows[k].edge >= E || rows[k].si == rows[k].sj) continue;  // no field on depth-only rows
    const double u = (rows[k].x - 0.5 * (s.W - 1)) / (0.5 * s.W),
                 v = (rows[k].y - 0.5 * (s.H - 1)) / (0.5 * s.H);
    const int col = mn * rows[k].edge + mb * rows[k].channel;
    ref.Phi(k, col) = rows[k].sl;
    ref.Phi(k, col + 1) = rows[k].sl * u;
    ref.Phi(k, col + 2) = rows[k].sl * v;
    for (int a = 0; a < nodes && nodes >= 2; ++a)
      for (int b = 0; b < nodes; ++b) {
        const double step = 2.0 / (nodes - 1), nu = -1.0 + b * step, nv = -1.0 + a * step;
        ref.Phi(k, col + 3 + a * nodes + b) = rows[k].sl *
                                              std::max(0.0, 1.0 - std::abs(u - nu) / step) *
                                              std::max(0.0, 1.0 - std::abs(v - nv) / step);
      }
  }
  const Eigen::MatrixXd PhiAP = ref.Phi.transpose() * AP;
  ref.Mfield =
      ref.Phi.transpose() * ref.Phi - PhiAP * (AP.transpose() * AP).inverse() * PhiAP.transpose();
  ref.tfield = ref.Phi.transpose() * (r - APC * (AP.transpose() * r));  // Φᵀ P⊥ r
  ref.V = V;
  for (const Row& row : rows) ref.row_edge.push_back(row.edge);
  for (int e = 0; e < E + s.numKeyframes(); ++e) {
    ref.source.push_back(e < E ? static_cast<int>(s.ii[e]) : e - E);
    double q = 0;
    for (int k = 0; k < M; ++k)
      if (rows[k].edge == e) q += r[k] * r[k];
    ref.q.push_back(q);
  }
  const Eigen::MatrixXd Pp = P.topLeftCorner(P6, Kp);
  const Eigen::MatrixXd Spp = Pp.transpose() * V.transpose() * V * Pp;
  ref.Sigma = Pp * Spp.inverse() * Pp.transpose();
  for (int e = 0; e < E + s.numKeyframes(); ++e) {
    std::vector<int> idx;
    for (int k = 0; k < M; ++k)
      if (rows[k].edge == e) idx.push_back(k);
    ref.rows.push_back(static_cast<int>(idx.size()));
    const int m = static_cast<int>(idx.size());
    Eigen::MatrixXd Ve(m, P6), Ree(m, m);
    Eigen::VectorXd re(m);
    double lev = 0;
    for (int a = 0; a < m; ++a) {
      Ve.row(a) = V.row(idx[a]);
      re[a] = r[idx[a]];
      for (int b = 0; b < m; ++b)
        Ree(a, b) = (a == b ? 1.0 : 0.0) - APC.row(idx[a]).dot(AP.row(idx[b]));
      lev += 1.0 - Ree(a, a);
    }
    ref.redundancy.push_back(m - lev);
    const Eigen::VectorXd g = Ve.transpose() * re;
    ref.g.push_back(g);
  }
  return ref;
}

/// 6 keyframes on a 6×8 grid, every pair an edge (30 edges, 24 free pose DoF), solved to the
/// optimum.
Snapshot solvedTiny(std::uint64_t seed) {
  sim::SyntheticSnapshotConfig cfg = testing::gridConfig(seed, 6, 6, 8);
  cfg.covisibility.edge_radius = 5;
  Snapshot s = sim::generateSyntheticSnapshot(cfg).snapshot;
  DbaOptions o = testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0.0, 0.0);
  solveDba(s, o);
  return s;
}

void expectRedundancyMatchesDenseReference() {
  const Snapshot s = solvedTiny(3);
  const DbaOptions o = testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0.0, 0.0);
  const EdgeReference ref = denseEdgeReference(s, o);
  // The white variance components (the calibrated solve's) and the nuisance model's record of
  // the same sums.
  const SelfCalibration vce = varianceComponents(s, o);
  SelfCalibrationOptions c;
  c.depth_noise = false;
  const SelfCalibration nuisance = selfCalibrate(s, o, c);
  ASSERT_EQ(vce.edges.size(), static_cast<std::size_t>(s.numEdges()));
  for (std::size_t e = 0; e < vce.edges.size(); ++e) {
    EXPECT_NEAR(vce.edges[e].redundancy, ref.redundancy[e], 1e-6 * (1 + ref.redundancy[e]))
        << "edge " << e;
    EXPECT_NEAR(vce.edges[e].vce_scale, vce.edges[e].chi2 / ref.redundancy[e], 1e-6);
    EXPECT_NEAR(nuisance.edges[e].redundancy, ref.redundancy[e], 1e-6 * (1 + ref.redundancy[e]))
        << "edge " << e;
  }
}

// The passes' products over pixels run in the pixel kernel's instruction set (dot_products.h):
// every variant this CPU runs.
TEST(SelfCalibration, RedundancyMatchesDenseReference) {
  testing::forEachKernelIsa([](kernel::Isa) { expectRedundancyMatchesDenseReference(); });
}

/// The nuisance method against the dense reference: the field's information and scores from
/// the full hat matrix (poses and depths) and the basis written from its definition, the
/// estimator re-done on them with a direct search of the likelihood (golden sections on each
/// log σ_g² in turn), and the covariance of DBA's estimate under the fitted noise model,
/// Σ Vᵀ (diag(s_e) + Φ D Φᵀ) V Σ. The snapshot is the tiny one with a flow error added to every
/// edge's targets and re-solved: an affine one of 0.1 px per coefficient and, for the spline
/// basis, a finer one (a random 0.03 px bump per channel, u·v for the one-cell 2 × 2 spline)
/// that only the tents can describe.
/// With depth_only, the tiny snapshot also has a stereo edge per source (σ 3x the claimed) and
/// RGB-D readings (α claimed 4x too high): factors without a field whose rows the hat matrix,
/// the field scores' projection and the white scales all include.
void expectNuisanceMatchesDenseReference(int nodes, bool depth_only = false) {
  SCOPED_TRACE("nodes " + std::to_string(nodes) + (depth_only ? ", stereo + RGB-D" : ""));
  DbaOptions o = testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0.0, 0.0);
  Snapshot s;
  if (depth_only) {
    sim::SyntheticSnapshotConfig cfg = testing::gridConfig(6, 6, 6, 8);
    cfg.covisibility.edge_radius = 5;
    s = sim::generateSyntheticSnapshot(cfg).snapshot;
    sim::StereoConfig stereo;
    stereo.weight_scale = o.weight_scale / 9.0;
    sim::addStereoEdges(s, stereo);
    sim::RgbdConfig rgbd;
    rgbd.alpha = 100.0;
    sim::addSensorDepth(s, rgbd);
    o.sensor_depth_weight = 4.0 * rgbd.alpha;
    s.validate();
  } else {
    s = solvedTiny(6);
  }
  std::mt19937_64 rng(99);
  std::normal_distribution<double> nd(0.0, 0.1);
  const int HW = static_cast<int>(s.pixelsPerFrame());
  for (int e = 0; e < s.numEdges(); ++e)
    for (int c = 0; c < 2 && s.ii[e] != s.jj[e]; ++c) {  // no field on a stereo edge
      const double a0 = nd(rng), a1 = nd(rng), a2 = nd(rng),
                   bump = nodes >= 2 ? 0.3 * nd(rng) : 0.0;
      float* t = &s.target[(static_cast<std::size_t>(e) * 2 + c) * HW];
      for (int p = 0; p < HW; ++p) {
        const double u = (p % s.W - 0.5 * (s.W - 1)) / (0.5 * s.W),
                     v = (p / s.W - 0.5 * (s.H - 1)) / (0.5 * s.H);
        t[p] += static_cast<float>(a0 + a1 * u + a2 * v +
                                   bump * (nodes == 2 ? u * v : (1 - u * u) * (1 - v * v)));
      }
    }
  solveDba(s, o);
  SelfCalibrationOptions c;
  c.depth_noise = false;  // the model's own covariance (the term: test_depth_noise.cpp)
  c.nuisance_nodes = nodes;
  const SelfCalibration cal = selfCalibrate(s, o, c);
  const EdgeReference ref = denseEdgeReference(s, o, nodes);
  const int E = s.numEdges(), mn = ref.field_coords, mb = mn / 2, G = nodes >= 2 ? 2 : 1;
  ASSERT_EQ(cal.nuisance_params, mn);
  // Each field is found (else the comparisons below are void). On the one-cell spline the tents
  // add only u·v per channel, which the poses take almost all of on this tiny grid: its σ_f is 0
  // (and the reference's must be too); the cell's sums are still checked through s_e and Σ.
  ASSERT_GT(cal.nuisance_sigma, 0.01);
  if (G == 2 && nodes > 2) {
    ASSERT_GT(cal.nuisance_fine_sigma, 0.005);
  }
  const auto groupOf = [&](int k) { return k % mb < 3 ? 0 : 1; };

  // The estimator on the dense quantities. Per edge, on the range of M_e = (Φᵀ P⊥ Φ)_ee (the
  // tents reproduce the affine field: M_e is singular), W = Λ^-½ Uᵀ, y = W t_e and per group
  // B_g = W A_g Wᵀ, A_g = Σ_{e' from the same source} M_ee' D_g M_e'e; then y ~ N(0, s_e I +
  // Σ_g σ_g² B_g), s_e and the σ_g² alternated.
  struct Edge {
    Eigen::VectorXd y, excess;
    std::vector<Eigen::MatrixXd> B;
    double q = 0, dof = 0, fit = 0;
  };
  std::vector<Edge> ed(E);
  for (int e = 0; e < E; ++e) {
    const Eigen::MatrixXd M = ref.Mfield.block(mn * e, mn * e, mn, mn);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(M);
    const Eigen::VectorXd& ev = eig.eigenvalues();
    std::vector<int> keep;
    for (int k = 0; k < mn; ++k)
      if (ev[k] > 1e-8 * ev.maxCoeff()) keep.push_back(k);
    Eigen::MatrixXd W(keep.size(), mn);
    for (std::size_t r = 0; r < keep.size(); ++r)
      W.row(r) = eig.eigenvectors().col(keep[r]).transpose() / std::sqrt(ev[keep[r]]);
    ed[e].y = W * ref.tfield.segment(mn * e, mn);
    ed[e].excess = Eigen::VectorXd::Zero(G);
    for (int g = 0; g < G; ++g) {
      Eigen::MatrixXd A = Eigen::MatrixXd::Zero(mn, mn);
      for (int f = 0; f < E; ++f) {
        if (ref.source[f] != ref.source[e]) continue;
        Eigen::MatrixXd Mef = ref.Mfield.block(mn * e, mn * f, mn, mn);
        for (int k = 0; k < mn; ++k)
          if (groupOf(k) != g) Mef.col(k).setZero();
        A += Mef * Mef.transpose();
      }
      ed[e].B.push_back(W * A * W.transpose());
      double trMgg = 0;
      for (int k = 0; k < mn; ++k)
        if (groupOf(k) == g) trMgg += M(k, k);
      ed[e].excess[g] = ed[e].B[g].trace() - trMgg;
    }
    ed[e].q = ref.q[e];
    ed[e].dof = ref.redundancy[e] - static_cast<double>(keep.size());
    ed[e].fit = ed[e].y.squaredNorm();
    ASSERT_GT(ed[e].dof, 0.5) << "edge " << e;
  }
  std::vector<double> se(E);
  for (int e = 0; e < E; ++e) se[e] = std::max(ed[e].q - ed[e].fit, 0.05 * ed[e].q) / ed[e].dof;
  Eigen::VectorXd theta = Eigen::VectorXd::Constant(G, 1e-3);
  auto loglik = [&](const Eigen::VectorXd& th) {
    double l = 0;
    for (int e = 0; e < E; ++e) {
      const int r = static_cast<int>(ed[e].y.size());
      Eigen::MatrixXd Cv = se[e] * Eigen::MatrixXd::Identity(r, r);
      for (int g = 0; g < G; ++g) Cv += th[g] * ed[e].B[g];
      const Eigen::LLT<Eigen::MatrixXd> llt(Cv);
      l -= 0.5 * (2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum() +
                  ed[e].y.dot(llt.solve(ed[e].y)));
    }
    return l;
  };
  for (int outer = 0; outer < 25; ++outer) {
    for (int sweep = 0; sweep < (G == 2 ? 3 : 1); ++sweep)
      for (int g = 0; g < G; ++g) {
        double lo = std::log(1e-12), hi = std::log(1.0);
        Eigen::VectorXd th = theta;
        for (int it = 0; it < 70; ++it) {
          const double a = lo + 0.382 * (hi - lo), b = lo + 0.618 * (hi - lo);
          th[g] = std::exp(a);
          const double la = loglik(th);
          th[g] = std::exp(b);
          if (la < loglik(th))
            lo = a;
          else
            hi = b;
        }
        theta[g] = std::exp(0.5 * (lo + hi));
      }
    for (int e = 0; e < E; ++e)
      se[e] = std::max(ed[e].q - ed[e].fit + theta.dot(ed[e].excess), 0.05 * ed[e].q) / ed[e].dof;
  }
  EXPECT_NEAR(cal.nuisance_sigma * cal.nuisance_sigma, theta[0], 1e-4 * theta[0]);
  if (G == 2) {
    EXPECT_NEAR(cal.nuisance_fine_sigma * cal.nuisance_fine_sigma, theta[1],
                1e-4 * theta[1] + 1e-9);
  }
  for (int e = 0; e < E; ++e) EXPECT_NEAR(cal.edges[e].inflation, se[e], 1e-4 * se[e]) << e;
  if (depth_only) {  // the readings' pooled scale
    double q = 0, red = 0;
    for (int k = 0; k < s.numKeyframes(); ++k) {
      q += ref.q[E + k];
      red += ref.redundancy[E + k];
    }
    ASSERT_GT(red, 1.0);
    EXPECT_NEAR(cal.sensor_depth_scale, q / red, 1e-6 * q / red);
  }

  // The covariance, with the method's own estimates.
  const double var[2] = {cal.nuisance_sigma * cal.nuisance_sigma,
                         cal.nuisance_fine_sigma * cal.nuisance_fine_sigma};
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(ref.V.cols(), ref.V.cols());
  for (int e = 0; e < E; ++e) {
    const Eigen::MatrixXd VPhi = ref.V.transpose() * ref.Phi.middleCols(mn * e, mn);
    for (int k = 0; k < mn; ++k) meat += var[groupOf(k)] * VPhi.col(k) * VPhi.col(k).transpose();
  }
  for (int k = 0; k < ref.V.rows(); ++k) {
    const int cl = ref.row_edge[k];  // an edge, or E + k for keyframe k's readings
    const double scale = cl < E ? cal.edges[cl].inflation : cal.sensor_depth_scale;
    meat += scale * ref.V.row(k).transpose() * ref.V.row(k);
  }
  const Eigen::MatrixXd expected = ref.Sigma * meat * ref.Sigma;
  const DbaCovariance cov = selfCalibratedCovariance(s, o, {}, cal);
  EXPECT_EQ(cov.summary().self_calibration.method, "nuisance");
  const std::vector<int> kf = s.graphKeyframes();
  for (std::size_t a = 0; a < kf.size(); ++a) {
    const Matrix6d got = cov.marginal(kf[a]);
    const Eigen::MatrixXd want = expected.block<6, 6>(6 * a, 6 * a);
    EXPECT_LE((got - want).norm(), 1e-6 * (1e-12 + want.norm())) << "keyframe " << kf[a];
  }
}

/// Inside a spline cell every active basis value is T_cell times the pixel's monomials: the
/// identity the nuisance sums rely on to run on 4 monomials instead of 7 values, checked at every
/// pixel of grids whose cells are uneven, against NuisanceBasis::eval.
TEST(SelfCalibration, NuisanceCellTransformReproducesTheBasis) {
  for (const auto& [nodes, H, W] :
       std::vector<std::array<int, 3>>{{0, 5, 7}, {2, 6, 9}, {3, 24, 32}, {4, 49, 61}, {8, 7, 5}}) {
    const NuisanceBasis b{nodes, H, W};
    const int na = b.active(), nm = b.monomials();
    std::vector<double> T(static_cast<std::size_t>(na * nm)), m(nm), value(na);
    std::vector<int> index(na);
    double worst = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const int cell = b.eval(x, y, index.data(), value.data());
        b.cellTransform(cell, T.data());
        b.monomial(x, y, m.data());
        for (int u = 0; u < na; ++u) {
          double v = 0;
          for (int j = 0; j < nm; ++j) v += T[u * nm + j] * m[j];
          worst = std::max(worst, std::abs(v - value[u]));
        }
      }
    EXPECT_LT(worst, 1e-12) << "nodes " << nodes << ", " << H << " x " << W;
  }
}

TEST(SelfCalibration, NuisanceMatchesDenseReference) {
  testing::forEachKernelIsa([](kernel::Isa) {
    expectNuisanceMatchesDenseReference(0);        // affine
    expectNuisanceMatchesDenseReference(2);        // affine + 2 × 2 tents: one spline cell
    expectNuisanceMatchesDenseReference(3);        // affine + 3 × 3 tents: two variance components
    expectNuisanceMatchesDenseReference(0, true);  // with stereo edges and RGB-D readings
  });
}

/// The factors on the depths alone, against the dense reference with their rows: a stereo edge
/// per source whose targets err 3x the claimed σ and RGB-D readings whose α is claimed 4x too
/// high, on the tiny snapshot solved to the optimum with them. Each stereo edge's redundancy and
/// scale, the readings' pooled scale, and nuisance's covariance Σ Vᵀ (diag(s_row) + Φ D Φᵀ) V Σ
/// with every row at its factor's scale. Without their own components the stereo edges and readings
/// kept factor 1: every comparison below fails.
void expectDepthOnlyFactorsMatchDenseReference() {
  sim::SyntheticSnapshotConfig cfg = testing::gridConfig(8, 6, 6, 8);
  cfg.covisibility.edge_radius = 5;
  Snapshot s = sim::generateSyntheticSnapshot(cfg).snapshot;
  DbaOptions o = testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0.0, 0.0);
  sim::StereoConfig stereo;
  stereo.weight_scale = o.weight_scale / 9.0;  // σ 3x what the confidences claim
  sim::addStereoEdges(s, stereo);
  sim::RgbdConfig rgbd;
  rgbd.alpha = 100.0;
  sim::addSensorDepth(s, rgbd);
  o.sensor_depth_weight = 4.0 * rgbd.alpha;  // claims 4x the readings' information
  s.validate();
  solveDba(s, o);
  const EdgeReference ref = denseEdgeReference(s, o);
  const int E = s.numEdges();
  SelfCalibrationOptions c;
  c.depth_noise = false;  // the model's own covariance
  const SelfCalibration vce = varianceComponents(s, o);
  int stereo_edges = 0;
  for (int e = 0; e < E; ++e) {
    if (s.ii[e] != s.jj[e]) continue;
    ++stereo_edges;
    ASSERT_GT(ref.rows[e], 0) << "stereo edge " << e;
    EXPECT_EQ(vce.edges[e].rows, static_cast<std::size_t>(ref.rows[e])) << e;
    EXPECT_NEAR(vce.edges[e].redundancy, ref.redundancy[e], 1e-6 * (1 + ref.redundancy[e])) << e;
    EXPECT_NEAR(vce.edges[e].inflation, ref.q[e] / ref.redundancy[e], 1e-6 * vce.edges[e].inflation)
        << e;
  }
  ASSERT_GT(stereo_edges, 2);
  double q = 0, red = 0;
  int rows = 0;
  for (int k = 0; k < s.numKeyframes(); ++k) {
    q += ref.q[E + k];
    red += ref.redundancy[E + k];
    rows += ref.rows[E + k];
  }
  ASSERT_GT(rows, 50);
  EXPECT_EQ(vce.sensor_depth_rows, static_cast<std::size_t>(rows));
  EXPECT_NEAR(vce.sensor_depth_redundancy, red, 1e-6 * red);
  EXPECT_NEAR(vce.sensor_depth_scale, q / red, 1e-6 * q / red);
  EXPECT_GT(vce.sensor_depth_scale, 2.0) << "the readings' 4x is not seen";
  const std::vector<int> kf = s.graphKeyframes();
  const auto expectMarginals = [&](const DbaCovariance& cov, const Eigen::MatrixXd& expected,
                                   const char* what) {
    for (std::size_t a = 0; a < kf.size(); ++a) {
      const Matrix6d got = cov.marginal(kf[a]);
      const Eigen::MatrixXd want = expected.block<6, 6>(6 * a, 6 * a);
      EXPECT_LE((got - want).norm(), 1e-6 * (1e-12 + want.norm())) << what << " keyframe " << kf[a];
    }
  };
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(ref.Sigma.rows(), ref.Sigma.cols());
  // Nuisance (affine field): every row at its factor's white scale, the fields at the method's
  // σ_a; its stereo scales and the readings' are the white variance components.
  c.nuisance_nodes = 0;
  const SelfCalibration nu = selfCalibrate(s, o, c);
  const EdgeReference fref = denseEdgeReference(s, o, 0);
  EXPECT_NEAR(nu.sensor_depth_scale, vce.sensor_depth_scale, 1e-9 * vce.sensor_depth_scale);
  meat.setZero();
  const int mn = fref.field_coords;
  for (int e = 0; e < E; ++e) {
    if (s.ii[e] == s.jj[e]) {
      EXPECT_NEAR(nu.edges[e].inflation, vce.edges[e].inflation, 1e-9 * vce.edges[e].inflation);
      continue;
    }
    const Eigen::MatrixXd VPhi = fref.V.transpose() * fref.Phi.middleCols(mn * e, mn);
    meat += nu.nuisance_sigma * nu.nuisance_sigma * VPhi * VPhi.transpose();
  }
  for (int k = 0; k < fref.V.rows(); ++k) {
    const int cl = fref.row_edge[k];
    const double scale = cl < E ? nu.edges[cl].inflation : nu.sensor_depth_scale;
    meat += scale * fref.V.row(k).transpose() * fref.V.row(k);
  }
  expectMarginals(selfCalibratedCovariance(s, o, {}, nu), fref.Sigma * meat * fref.Sigma,
                  "nuisance");
}

TEST(SelfCalibration, DepthOnlyFactorsMatchDenseReference) {
  testing::forEachKernelIsa([](kernel::Isa) { expectDepthOnlyFactorsMatchDenseReference(); });
}

/// The median of the per-edge inflations (edges with pixels).
double medianInflation(const SelfCalibration& c) {
  std::vector<double> v;
  for (const EdgeCalibration& e : c.edges)
    if (e.rows > 0) v.push_back(e.inflation);
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

TEST(SelfCalibration, MatchingWhiteNoiseIsLeftAlone) {
  const sim::Scenario sc(smallScenario(11, 24, 32));
  const sim::SimulatedSnapshot sim = sc.simulate(0, 0);
  const DbaOptions o = sc.config().engineOptions();
  SelfCalibrationOptions c;
  // The calibration's own share: the depths' second-order term (on by default) adds what the
  // linearization misses, white or not (30-50 % of the trace on this scene; its Monte Carlo with
  // matching white noise: test_depth_noise.cpp).
  c.depth_noise = false;
  const SelfCalibration cal = selfCalibrate(sim.snapshot, o, c);
  EXPECT_NEAR(medianInflation(cal), 1.0, 0.1);
  EXPECT_NEAR(cal.global_scale, 1.0, 0.05);
  // The pose covariance moves little (trace of every marginal): by less than 10 %.
  const DbaCovariance raw(sim.snapshot, o),
      calib = selfCalibratedCovariance(sim.snapshot, o, {}, cal);
  for (int k : raw.keyframes()) {
    const double tr = raw.marginal(k).trace();
    if (tr == 0) continue;
    EXPECT_NEAR(calib.marginal(k).trace() / tr, 1.0, 0.1) << "keyframe " << k;
  }
  // The white variance components per edge: thousands of residuals each, so every edge is
  // within 15 %.
  for (const EdgeCalibration& e : varianceComponents(sim.snapshot, o).edges)
    if (e.rows > 500) {
      EXPECT_NEAR(e.vce_scale, 1.0, 0.15) << "edge " << e.edge;
    }
}

/// The nuisance calibration hands its own linearization to selfCalibratedCovariance, which then
/// does not linearize again: the covariances are those of a fresh linearization, and with
/// depth variances (which need the depth terms the handed one lacks) it linearizes anew.
TEST(SelfCalibration, HandedLinearizationGivesTheSameCovariance) {
  const sim::Scenario sc(smallScenario(13, 24, 32));
  const sim::SimulatedSnapshot sim = sc.simulate(0, 0);
  const DbaOptions o = sc.config().engineOptions();
  // Both of selfCalibratedCovariance's paths for a reduced covariance: with the depths' term
  // (the default) and without it.
  for (bool depth_noise : {true, false}) {
    SCOPED_TRACE(depth_noise ? "depth noise on" : "depth noise off");
    SelfCalibrationOptions c;
    c.depth_noise = depth_noise;
    const SelfCalibration cal = selfCalibrate(sim.snapshot, o, c);
    ASSERT_TRUE(cal.fit && cal.fit->linearization) << "the calibration hands over no linearization";
    SelfCalibration fresh = cal;
    auto unlinearized = std::make_shared<SelfCalibrationFit>(*cal.fit);
    unlinearized->linearization.reset();
    fresh.fit = unlinearized;
    CovarianceOptions depths;
    depths.depth_variances = true;
    const DbaCovariance handed = selfCalibratedCovariance(sim.snapshot, o, {}, cal),
                        anew = selfCalibratedCovariance(sim.snapshot, o, {}, fresh),
                        with_depths = selfCalibratedCovariance(sim.snapshot, o, depths, cal);
    ASSERT_EQ(handed.keyframes(), anew.keyframes());
    for (int k : anew.keyframes()) {
      const Matrix6d want = anew.marginal(k);
      EXPECT_LE((handed.marginal(k) - want).norm(), 1e-12 * (1e-300 + want.norm())) << k;
      EXPECT_LE((with_depths.marginal(k) - want).norm(), 1e-12 * (1e-300 + want.norm())) << k;
    }
    // A calibration or a linearization of another snapshot is refused, not used.
    SelfCalibration other = cal;
    other.edges[1].j = other.edges[1].i;
    EXPECT_THROW(selfCalibratedCovariance(sim.snapshot, o, {}, other), std::invalid_argument);
    auto lin = std::make_shared<DbaNormalEquations>(*cal.fit->linearization);
    lin->keyframes.pop_back();
    detail::GivenModel foreign;
    foreign.reduced_covariance = cal.fit->reduced_covariance;
    foreign.linearization = lin;
    EXPECT_THROW(foreign.build(sim.snapshot, o, {}), std::invalid_argument);
    // A calibration without its fitted model is not silently the stated model.
    SelfCalibration unfitted = cal;
    unfitted.fit.reset();
    EXPECT_THROW(selfCalibratedCovariance(sim.snapshot, o, {}, unfitted), std::invalid_argument);
    const int src = static_cast<int>(sim.snapshot.ii[0]);
    const std::vector<float> sd = with_depths.inverseDepthSigma(src);
    ASSERT_EQ(sd.size(), sim.snapshot.pixelsPerFrame());
    EXPECT_TRUE(std::any_of(sd.begin(), sd.end(), [](float v) { return v > 0; }));
  }
}

/// DROID's stereo edges (k, k) act on the depths alone and RGB-D sensor depths likewise: the
/// residual pass must treat them as the linearization does. A stereo edge treated as a pose
/// factor of T_ji = I would read its disparity as a flow error, and the shared field variance
/// with it (σ_a 0.1 px against 0.003 px without stereo edges); sensor depths left out of the
/// depth information would make the depths absorb too much and the white scale too large.
TEST(SelfCalibration, StereoAndSensorDepthsAreFactorsOnTheDepths) {
  const sim::Scenario sc(smallScenario(14, 24, 32));
  const sim::SimulatedSnapshot sim = sc.simulate(0, 0);
  const DbaOptions o = sc.config().engineOptions();
  SelfCalibrationOptions c;
  const SelfCalibration mono = selfCalibrate(sim.snapshot, o, c);
  Snapshot stereo = sim.snapshot;
  sim::StereoConfig sc_stereo;
  sc_stereo.weight_scale = o.weight_scale;  // the noise its confidences claim
  sim::addStereoEdges(stereo, sc_stereo);
  stereo.validate();
  ASSERT_GT(stereo.numEdges(), sim.snapshot.numEdges());
  const SelfCalibration st = selfCalibrate(stereo, o, c);
  EXPECT_LT(st.nuisance_sigma, 0.02) << "mono " << mono.nuisance_sigma;
  EXPECT_NEAR(medianInflation(st), medianInflation(mono), 0.1 * medianInflation(mono));
  EXPECT_NEAR(st.global_scale, 1.0, 0.05);
  // Each stereo edge has a variance component of its own; its noise is as claimed here.
  int stereo_edges = 0;
  for (const EdgeCalibration& e : st.edges)
    if (e.i == e.j) {
      ++stereo_edges;
      EXPECT_GT(e.rows, 100u) << "stereo edge " << e.edge;
      EXPECT_NEAR(e.inflation, 1.0, 0.15) << "stereo edge " << e.edge;
    }
  EXPECT_GT(stereo_edges, 0);
  EXPECT_EQ(st.sensor_depth_rows, 0u);
  EXPECT_EQ(st.sensor_depth_scale, 1.0);
  EXPECT_NO_THROW(selfCalibratedCovariance(stereo, o, {}, st));

  Snapshot rgbd = sim.snapshot;
  sim::RgbdConfig rc;
  rgbd.validate();
  sim::addSensorDepth(rgbd, rc);
  DbaOptions orgbd = o;
  orgbd.sensor_depth_weight = rc.alpha;  // the noise the readings have
  const SelfCalibration sd = selfCalibrate(rgbd, orgbd, c);
  EXPECT_NEAR(sd.global_scale, 1.0, 0.05);
  EXPECT_NEAR(medianInflation(sd), 1.0, 0.1);
  EXPECT_GT(sd.sensor_depth_rows, 1000u);
  EXPECT_NEAR(sd.sensor_depth_scale, 1.0, 0.1);
  // Depths pinned by exact readings on every pixel take nothing from the flow rows: their
  // leverages add up to the poses' share (< 6 per keyframe), not one more per depth.
  Snapshot pinned = sim.snapshot;
  sim::RgbdConfig exact;
  exact.valid_fraction = 1.0;
  exact.noise = false;
  sim::addSensorDepth(pinned, exact);
  DbaOptions opinned = o;
  opinned.sensor_depth_weight = 1e8;
  double leverage = 0;
  for (const EdgeCalibration& e : selfCalibrate(pinned, opinned, c).edges)
    leverage += static_cast<double>(e.rows) - e.redundancy;
  EXPECT_LT(leverage, 6.0 * pinned.numKeyframes());
}

TEST(SelfCalibration, WrongWeightScaleIsCorrected) {
  const sim::Scenario sc(smallScenario(12, 24, 32));
  const sim::SimulatedSnapshot sim = sc.simulate(0, 0);
  const DbaOptions right = sc.config().engineOptions();
  const DbaCovariance truth(sim.snapshot, right);
  // The calibrated covariance does not depend on the claimed scale, however far off (the white
  // scales' bounds are relative to the pooled scale): 4x, and the 1e-9 and 1e6 of a user who
  // leaves DROID's scale behind, with the depths' term (the default, scale-free given the white
  // factors) and without it.
  for (bool depth_noise : {true, false}) {
    SelfCalibrationOptions c;
    c.depth_noise = depth_noise;
    const DbaCovariance at_right =
        selfCalibratedCovariance(sim.snapshot, right, {}, selfCalibrate(sim.snapshot, right, c));
    EXPECT_EQ(at_right.summary().self_calibration.depth_noise_share > 0, depth_noise);
    for (double claim : {4.0, 1e-9, 1e6}) {
      SCOPED_TRACE("weight scale x " + std::to_string(claim) +
                   (depth_noise ? ", depths' term" : ""));
      DbaOptions wrong = right;
      wrong.weight_scale *= claim;
      const SelfCalibration cal = selfCalibrate(sim.snapshot, wrong, c);
      EXPECT_NEAR(cal.global_scale, claim, 0.05 * claim);
      EXPECT_NEAR(medianInflation(cal), claim, 0.1 * claim);
      const DbaCovariance at_wrong = selfCalibratedCovariance(sim.snapshot, wrong, {}, cal);
      // The field's likelihood is maximized to a tolerance relative to its value, which moves
      // with the scale (measured: up to 1.5e-4 at 1e-9 in Release, 5.2e-4 under the sanitizers'
      // -O1; 2e-6 at 1e6), far below the 45-70x of absolute bounds.
      const double tolerance = claim == 4.0 ? 1e-6 : 2e-3;
      for (int k : at_right.keyframes()) {
        const Matrix6d want = at_right.marginal(k);
        EXPECT_LE((at_wrong.marginal(k) - want).norm(), tolerance * (1e-300 + want.norm()))
            << "keyframe " << k << ": trace " << at_wrong.marginal(k).trace() << " against "
            << want.trace();
      }
    }
  }
  // Without the term, against the raw covariance of the right scale; the summary says which
  // self-calibration the covariance comes from.
  DbaOptions wrong = right;
  wrong.weight_scale *= 4.0;  // claims 4x the information the targets have
  SelfCalibrationOptions c;
  c.depth_noise = false;
  const SelfCalibration cal = selfCalibrate(sim.snapshot, wrong, c);
  const DbaCovariance calib = selfCalibratedCovariance(sim.snapshot, wrong, {}, cal);
  EXPECT_EQ(calib.summary().self_calibration.method, "nuisance");
  EXPECT_EQ(calib.summary().self_calibration.edge_factor, cal.inflations());
  EXPECT_NE(calib.summary().brief().find("self-calibrated (nuisance)"), std::string::npos);
  double ratio = 0;
  int count = 0;
  for (int k : truth.keyframes()) {
    const double tr = truth.marginal(k).trace();
    if (tr == 0) continue;
    ratio += calib.marginal(k).trace() / tr;
    ++count;
  }
  EXPECT_NEAR(ratio / count, 1.0, 0.15);
}

TEST(SelfCalibration, NoiseFreeResidualsAreClampedNotSingular) {
  // Targets without noise: the residuals show (almost) no error. The white scales stop at their
  // lower bound, the covariances stay finite and positive.
  sim::ScenarioConfig cfg = smallScenario(13, 24, 32);
  cfg.noise.amplitude = 0.0;
  const sim::Scenario sc(cfg);
  const sim::SimulatedSnapshot sim = sc.simulate(0, 0);
  const DbaOptions o = sc.config().engineOptions();
  const SelfCalibration cal = selfCalibrate(sim.snapshot, o, {});
  for (const EdgeCalibration& e : cal.edges) {
    EXPECT_GT(e.inflation, 0) << "edge " << e.edge;
    EXPECT_TRUE(std::isfinite(e.inflation) && std::isfinite(e.correlation));
  }
  const DbaCovariance cov = selfCalibratedCovariance(sim.snapshot, o, {}, cal);
  for (int k : cov.keyframes()) {
    const Matrix6d P = cov.marginal(k);
    EXPECT_TRUE(P.allFinite()) << "keyframe " << k;
    if (P.trace() > 0) {
      EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(P).eigenvalues().minCoeff(), 0.0);
    }
  }
}

TEST(SelfCalibration, OptionsAreChecked) {
  // The nuisance field: affine (0) or 2..8 nodes per side; 1 node is no spline.
  for (int nodes : {-1, 1, 9}) {
    SelfCalibrationOptions n;
    n.nuisance_nodes = nodes;
    EXPECT_THROW(n.validate(), std::invalid_argument) << nodes;
  }
  for (int nodes : {0, 2, 8}) {
    SelfCalibrationOptions n;
    n.nuisance_nodes = nodes;
    EXPECT_NO_THROW(n.validate()) << nodes;
  }
  EXPECT_EQ(SelfCalibrationOptions{}.nuisance_nodes, 4);  // the default
  const Snapshot s = solvedTiny(4);
  EXPECT_THROW(inflateWeights(s, {1.0}), std::invalid_argument);
}

TEST(SelfCalibration, DistanceFromOptimumIsZeroAtTheOptimumAndLargeAway) {
  Snapshot s = solvedTiny(5);
  const DbaOptions o = testing::gaugeOptions(GaugeOptions::Type::TwoPose, 0.0, 0.0);
  const OptimumDistance at = distanceFromOptimum(s, o);
  EXPECT_LT(at.step_sigma * at.step_sigma, 0.1 * at.free_dof);
  // Move the last keyframe by a few of its standard deviations: the step reports it.
  const DbaCovariance cov(s, o);
  const int k = cov.keyframes().back();
  const Matrix6d C = cov.marginal(k);
  Vector6d xi = Vector6d::Zero();
  xi[0] = 5.0 * std::sqrt(C(0, 0));
  s.setT_wc(k, s.T_wc(k) * expSE3(xi));
  const OptimumDistance away = distanceFromOptimum(s, o);
  EXPECT_GT(away.step_sigma, 2.0);
  EXPECT_TRUE(away.unreliable());
  EXPECT_FALSE(at.unreliable());
}

}  // namespace
}  // namespace dbacov
