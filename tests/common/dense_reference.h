// Independent dense reference for the covariance engine (tests only).
//
// Builds the full information matrix over (graph poses, every depth variable) as JᵀΛJ of a dense
// Jacobian, applies the gauge densely (a prior, or a selection/projection matrix whose
// minimal-gauge direction comes from finite differences of the centre distance), and inverts the
// whole thing: no Schur complement, no block storage, no sparse solver.
#pragma once

#include <vector>

#include <Eigen/Dense>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::testing {

/// The full normal equations over (6 per graph keyframe, then every depth variable), the gauge as
/// a basis P (full → reduced coordinates) and, for soft two-pose gauges, the priors added to H.
struct DenseFullSystem {
  std::vector<int> keyframes;                   ///< slot → keyframe
  std::vector<std::pair<int, int>> depth_vars;  ///< (keyframe, pixel) of each depth variable
  Eigen::MatrixXd H;                            ///< JᵀΛJ (+ gauge priors)
  Eigen::VectorXd g;                            ///< JᵀΛr
  Eigen::MatrixXd P;                            ///< gauge basis
  int numPoseDims() const { return 6 * static_cast<int>(keyframes.size()); }
  int slotOf(int keyframe) const {
    for (std::size_t s = 0; s < keyframes.size(); ++s)
      if (keyframes[s] == keyframe) return static_cast<int>(s);
    return -1;
  }
};

inline DenseFullSystem denseFullSystem(const Snapshot& s, const DbaOptions& o) {
  DenseFullSystem sys;
  sys.keyframes = s.graphKeyframes();
  const int n = static_cast<int>(sys.keyframes.size());
  const int HW = static_cast<int>(s.pixelsPerFrame());
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);

  // Every used factor row, with depth variables created on first use.
  struct Row {
    int slot_i, slot_j, depth;
    Eigen::Matrix<double, 1, 6> Ji, Jj;
    double Jd, r, w;
  };
  std::vector<Row> rows;
  std::vector<int> depth_index(static_cast<std::size_t>(s.numKeyframes()) * HW, -1);
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    // A stereo edge (ii == jj) reprojects by the fixed rig transform: no pose Jacobians.
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
        const double w = o.weight_scale * s.weightPlane(e, c)[p];
        if (w == 0) continue;
        int& di = depth_index[static_cast<std::size_t>(i) * HW + p];
        if (di < 0) {
          di = static_cast<int>(sys.depth_vars.size());
          sys.depth_vars.emplace_back(i, p);
        }
        if (stereo) f.J_i.setZero(), f.J_j.setZero();
        rows.push_back(
            {sys.slotOf(i), sys.slotOf(j), di, f.J_i.row(c), f.J_j.row(c), f.J_d[c], f.r[c], w});
      }
    }
  }
  // RGB-D: α·(d_sens − d)² on every source pixel with a sensor reading (r = d_sens − d).
  if (s.disps_sens && o.sensor_depth_weight > 0) {
    for (int i : sys.keyframes) {
      if (std::find(s.ii.begin(), s.ii.end(), i) == s.ii.end()) continue;
      for (int p = 0; p < HW; ++p) {
        const double d = s.disps[static_cast<std::size_t>(i) * HW + p];
        const double ds = (*s.disps_sens)[static_cast<std::size_t>(i) * HW + p];
        if (!(d > 0) || !(ds > 0)) continue;
        int& di = depth_index[static_cast<std::size_t>(i) * HW + p];
        if (di < 0) {
          di = static_cast<int>(sys.depth_vars.size());
          sys.depth_vars.emplace_back(i, p);
        }
        rows.push_back({sys.slotOf(i), sys.slotOf(i), di, Eigen::Matrix<double, 1, 6>::Zero(),
                        Eigen::Matrix<double, 1, 6>::Zero(), -1.0, ds - d, o.sensor_depth_weight});
      }
    }
  }
  const int dim = 6 * n + static_cast<int>(sys.depth_vars.size());
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(rows.size(), dim);
  Eigen::VectorXd w(rows.size()), r(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    J.block<1, 6>(k, 6 * rows[k].slot_i) = rows[k].Ji;
    J.block<1, 6>(k, 6 * rows[k].slot_j) += rows[k].Jj;
    J(k, 6 * n + rows[k].depth) = rows[k].Jd;
    w[k] = rows[k].w;
    r[k] = rows[k].r;
  }
  sys.H = J.transpose() * w.asDiagonal() * J;
  sys.g = J.transpose() * w.cwiseProduct(r);

  // Gauge: P maps reduced coordinates to the full ones; priors are added in full coordinates.
  std::vector<int> sources;
  for (auto k : s.ii)
    if (std::find(sources.begin(), sources.end(), static_cast<int>(k)) == sources.end())
      sources.push_back(static_cast<int>(k));
  std::sort(sources.begin(), sources.end());
  const bool droid = o.gauge.type == GaugeOptions::Type::Droid;
  const int ga = sys.slotOf(sources[0]), gb = sources.size() > 1 ? sys.slotOf(sources[1]) : -1;
  std::vector<Eigen::VectorXd> cols;  // columns of P
  auto unit = [&](int k) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(dim);
    v[k] = 1;
    return v;
  };
  for (int k = 0; k < dim; ++k) {
    const int slot = k < 6 * n ? k / 6 : -1;
    if (droid) {  // DROID held the poses below t0
      if (slot < 0 || sys.keyframes[slot] >= *s.t0) cols.push_back(unit(k));
      continue;
    }
    if (slot != ga && slot != gb) {
      cols.push_back(unit(k));
      continue;
    }
    if (o.gauge.type == GaugeOptions::Type::TwoPose) {
      const double sigma = (k % 6) < 3 ? o.gauge.sigma_trans : o.gauge.sigma_rot;
      if (sigma > 0) {
        cols.push_back(unit(k));
        sys.H(k, k) += 1.0 / (sigma * sigma);
      }
    }
  }
  if (o.gauge.type == GaugeOptions::Type::Minimal) {
    // Direction that changes |c_b − c_a|, by central differences over ξ_b.
    const Eigen::Isometry3d Ta = s.T_wc(sys.keyframes[ga]), Tb = s.T_wc(sys.keyframes[gb]);
    Eigen::Matrix<double, 1, 6> dist;
    for (int k = 0; k < 6; ++k) {
      Vector6d dx = Vector6d::Zero();
      dx[k] = 1e-6;
      dist[k] = ((Tb * expSE3(dx)).translation() - Ta.translation()).norm() -
                ((Tb * expSE3(-dx)).translation() - Ta.translation()).norm();
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(Eigen::MatrixXd(dist), Eigen::ComputeFullV);
    for (int c = 1; c < 6; ++c) {
      Eigen::VectorXd v = Eigen::VectorXd::Zero(dim);
      v.segment<6>(6 * gb) = svd.matrixV().col(c);
      cols.push_back(v);
    }
  }
  sys.P.resize(dim, cols.size());
  for (std::size_t c = 0; c < cols.size(); ++c) sys.P.col(c) = cols[c];
  return sys;
}

struct DenseReference {
  std::vector<int> keyframes;  ///< slot → keyframe
  Eigen::MatrixXd Sigma_full;  ///< covariance of (6 per slot, then depths), gauge applied
  std::vector<std::pair<int, int>> depth_vars;  ///< (keyframe, pixel) of each depth variable
  int numPoseDims() const { return 6 * static_cast<int>(keyframes.size()); }
  Matrix6d marginal(int keyframe) const {
    const int s = slotOf(keyframe);
    return Sigma_full.block<6, 6>(6 * s, 6 * s);
  }
  Eigen::Matrix<double, 6, 6> cross(int a, int b) const {
    return Sigma_full.block<6, 6>(6 * slotOf(a), 6 * slotOf(b));
  }
  int slotOf(int keyframe) const {
    for (std::size_t s = 0; s < keyframes.size(); ++s)
      if (keyframes[s] == keyframe) return static_cast<int>(s);
    return -1;
  }
};

/// Σ = P (PᵀHP)⁻¹ Pᵀ of the full system: the reference for every covariance the engine returns.
inline DenseReference denseReference(const Snapshot& s, const DbaOptions& o) {
  const DenseFullSystem sys = denseFullSystem(s, o);
  DenseReference ref;
  ref.keyframes = sys.keyframes;
  ref.depth_vars = sys.depth_vars;
  ref.Sigma_full = sys.P * (sys.P.transpose() * sys.H * sys.P).inverse() * sys.P.transpose();
  return ref;
}

}  // namespace dbacov::testing
