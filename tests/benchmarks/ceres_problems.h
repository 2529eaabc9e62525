// The DBA problem as Ceres sees it (peer comparison, benchmarks only).
//
// Parameter blocks are the perturbations themselves — ξ_k ∈ R^6 of every graph keyframe with
// T_wc = T_wc⁰·Exp(ξ_k) (conventions §3) and δd for every used inverse depth — evaluated at 0, so
// ceres::Covariance returns covariances in dbacov's tangent directly. Gauge keyframes (the droid
// preset's hard two-pose gauge) are constant blocks.
#pragma once

#include <map>
#include <memory>
#include <vector>

#include <ceres/ceres.h>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/gauge.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::bench {

/// √w-weighted pixel factor r = √w ⊙ (target − π(T_cw_j Exp(−ξ_j)·T_wc_i Exp(ξ_i) X(d⁰ + δd))).
class PixelCost final : public ceres::SizedCostFunction<2, 6, 6, 1> {
 public:
  PixelCost(const Eigen::Isometry3d& T_wc_i, const Eigen::Isometry3d& T_wc_j,
            const PinholeIntrinsics& K, double x, double y, double d0, double tx, double ty,
            double sw0, double sw1)
      : Ti_(T_wc_i), Tj_(T_wc_j), K_(K), x_(x), y_(y), d0_(d0), tx_(tx), ty_(ty), sw_(sw0, sw1) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const Eigen::Isometry3d Ti = Ti_ * expSE3(Eigen::Map<const Vector6d>(p[0]));
    const Eigen::Isometry3d Tj = Tj_ * expSE3(Eigen::Map<const Vector6d>(p[1]));
    const Eigen::Isometry3d T_ji = Tj.inverse() * Ti;
    PixelFactorLinearization f;
    linearizePixelFactor(T_ji.linear(), T_ji.translation(), K_, x_, y_, d0_ + p[2][0], tx_, ty_,
                         &f);
    using Jac = Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>>;
    Eigen::Map<Eigen::Vector2d> r(residuals);
    r = sw_.cwiseProduct(f.r);
    if (jacobians) {
      // Exact at ξ = 0, where ceres::Covariance evaluates them.
      if (jacobians[0]) Jac(jacobians[0]).noalias() = sw_.asDiagonal() * f.J_i;
      if (jacobians[1]) Jac(jacobians[1]).noalias() = sw_.asDiagonal() * f.J_j;
      if (jacobians[2]) {
        Eigen::Map<Eigen::Vector2d> jd(jacobians[2]);
        jd = sw_.cwiseProduct(f.J_d);
      }
    }
    return true;
  }

 private:
  Eigen::Isometry3d Ti_, Tj_;
  PinholeIntrinsics K_;
  double x_, y_, d0_, tx_, ty_;
  Eigen::Vector2d sw_;
};

/// The full problem: every used pixel factor, pose and depth blocks.
struct CeresFullProblem {
  std::unique_ptr<ceres::Problem> problem;
  std::map<int, std::unique_ptr<double[]>> xi;  ///< keyframe → its 6 parameters
  std::vector<double> dd;                       ///< depth perturbations
  std::vector<int> free_keyframes;
};

inline CeresFullProblem buildCeresFullProblem(const Snapshot& s, const DbaOptions& o) {
  CeresFullProblem c;
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  c.problem = std::make_unique<ceres::Problem>(po);
  const std::vector<int> kf = s.graphKeyframes();
  for (int k : kf) {
    c.xi[k] = std::make_unique<double[]>(6);
    std::fill(c.xi[k].get(), c.xi[k].get() + 6, 0.0);
    c.problem->AddParameterBlock(c.xi[k].get(), 6);
  }
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const int HW = static_cast<int>(s.pixelsPerFrame());
  // One depth block per (source keyframe, pixel) that some factor uses.
  std::map<std::pair<int, int>, int> depth_of;
  std::vector<std::tuple<int, int, int>> factors;  // (edge, pixel, depth)
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    const Eigen::Isometry3d T_ji = s.T_cw(j) * s.T_wc(i);
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(i) * HW + p];
      if (!(d > 0) || (s.weightPlane(e, 0)[p] == 0 && s.weightPlane(e, 1)[p] == 0)) continue;
      const Eigen::Vector3d Y =
          transferPoint(T_ji.linear(), T_ji.translation(), K, p % s.W, p / s.W, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      auto [it, fresh] = depth_of.emplace(std::make_pair(i, p), static_cast<int>(depth_of.size()));
      factors.emplace_back(e, p, it->second);
    }
  }
  c.dd.assign(depth_of.size(), 0.0);  // no reallocation after the blocks point into it
  for (const auto& [e, p, k] : factors) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    const double d = s.disps[static_cast<std::size_t>(i) * HW + p];
    auto* cost =
        new PixelCost(s.T_wc(i), s.T_wc(j), K, p % s.W, p / s.W, d, s.targetPlane(e, 0)[p],
                      s.targetPlane(e, 1)[p], std::sqrt(o.weight_scale * s.weightPlane(e, 0)[p]),
                      std::sqrt(o.weight_scale * s.weightPlane(e, 1)[p]));
    c.problem->AddResidualBlock(cost, nullptr, c.xi[i].get(), c.xi[j].get(), &c.dd[k]);
  }
  const GaugeParameterization g = makeGauge(o.gauge, s, kf);
  for (int slot : g.gauge_slots) c.problem->SetParameterBlockConstant(c.xi[kf[slot]].get());
  for (std::size_t a = 0; a < kf.size(); ++a)
    if (std::find(g.gauge_slots.begin(), g.gauge_slots.end(), static_cast<int>(a)) ==
        g.gauge_slots.end())
      c.free_keyframes.push_back(kf[a]);
  return c;
}

/// r = U x over the free keyframes' tangents, with UᵀU = S the reduced (gauge-removed) system.
class ReducedCost final : public ceres::CostFunction {
 public:
  explicit ReducedCost(Eigen::MatrixXd U) : U_(std::move(U)) {
    set_num_residuals(static_cast<int>(U_.rows()));
    for (int b = 0; b < U_.cols() / 6; ++b) mutable_parameter_block_sizes()->push_back(6);
  }
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const int nb = static_cast<int>(U_.cols() / 6);
    Eigen::VectorXd x(U_.cols());
    for (int b = 0; b < nb; ++b) x.segment<6>(6 * b) = Eigen::Map<const Vector6d>(p[b]);
    Eigen::Map<Eigen::VectorXd> r(residuals, U_.rows());
    r = U_ * x;
    if (jacobians)
      for (int b = 0; b < nb; ++b)
        if (jacobians[b]) {
          Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> J(jacobians[b],
                                                                                  U_.rows(), 6);
          J = U_.middleCols<6>(6 * b);
        }
    return true;
  }

 private:
  Eigen::MatrixXd U_;
};

}  // namespace dbacov::bench
