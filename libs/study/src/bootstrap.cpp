// The parametric bootstrap of the nuisance self-calibration (bootstrap.h).
#include "dbacov/study/bootstrap.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/gauge.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/nuisance_basis.h"
#include "dbacov/core/parallel.h"
#include "dbacov/core/se3.h"
#include "dbacov/core/self_calibration_fit.h"

namespace dbacov {

namespace {

/// One replicate: the snapshot with targets π(state) + noise of the fitted model (a stereo edge
/// ii == jj: through the rig, white at its own scale, no field) and sensor readings (RGB-D)
/// d(state) + white noise at theirs, solved from the state and calibrated like the snapshot
/// (nuisance). Returns [joint NEES, NEES of each slot (0 for a fixed one)] of the
/// state against the replicate's estimate and covariance, or an empty vector when the solve did
/// not converge or the replicate's covariance could not be computed.
Eigen::VectorXd replicate(const Snapshot& s, const DbaOptions& o, const DbaSolverOptions& solver,
                          const SelfCalibration& cal, const NuisanceBasis& basis,
                          const std::vector<int>& keyframes, const SelfCalibrationOptions& opts,
                          BootstrapResampling resampling, unsigned long long seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Snapshot b = s;
  const int HW = static_cast<int>(s.pixelsPerFrame()), mb = basis.perChannel(), na = basis.active();
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const double sd[2] = {cal.nuisance_sigma, cal.nuisance_fine_sigma};
  std::vector<int> index(na);
  std::vector<double> value(na), field(2 * mb);
  const bool wild = resampling == BootstrapResampling::Wild;
  std::bernoulli_distribution sign(0.5);
  struct Row {
    std::size_t at;  ///< index into target
    int pixel, channel;
    double pred, lam, residual;  ///< residual: the snapshot's target − pred
  };
  std::vector<Row> rows;
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    const bool stereo = i == j;  // the fixed rig; white noise only (nuisance fits no field)
    for (int k = 0; k < 2 * mb; ++k) field[k] = stereo ? 0.0 : sd[basis.groupOf(k)] * n01(rng);
    const Eigen::Isometry3d T_ji = stereo ? s.stereoRig() : s.T_cw(j) * s.T_wc(i);
    const Eigen::Matrix3d R = T_ji.linear();
    const Eigen::Vector3d t = T_ji.translation();
    // The edge's used rows: target index, predicted flow and information.
    rows.clear();
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(i) * HW + p];
      const double lam[2] = {o.weight_scale * s.weightPlane(e, 0)[p],
                             o.weight_scale * s.weightPlane(e, 1)[p]};
      if (!(d > 0) || !(lam[0] > 0 || lam[1] > 0)) continue;
      const Eigen::Vector3d Y = transferPoint(R, t, K, p % s.W, p / s.W, d);
      if (!keepPixelFactor(o, d, Y.z())) continue;
      const double pred[2] = {K.fx * Y.x() / Y.z() + K.cx, K.fy * Y.y() / Y.z() + K.cy};
      for (int c = 0; c < 2; ++c)
        if (lam[c] > 0) {
          const std::size_t at = (static_cast<std::size_t>(e) * 2 + c) * HW + p;
          rows.push_back({at, p, c, pred[c], lam[c], s.target[at] - pred[c]});
        }
    }
    // Wild: the row's residual r with a random sign, scaled by sqrt(s_e / mean λr²) so that the
    // edge's white energy is the fitted s_e per row, as in the parametric draw.
    double wild_scale = 0;
    if (wild) {
      double q = 0;
      for (const Row& w : rows) q += w.lam * w.residual * w.residual;
      if (q > 0) wild_scale = std::sqrt(cal.edges[e].inflation * rows.size() / q);
    }
    const double white = std::sqrt(cal.edges[e].inflation);
    int last = -1;
    for (const Row& w : rows) {
      if (w.pixel != last) basis.eval(w.pixel % s.W, w.pixel / s.W, index.data(), value.data());
      last = w.pixel;
      double n = wild ? wild_scale * w.residual * (sign(rng) ? 1.0 : -1.0)
                      : white / std::sqrt(w.lam) * n01(rng);
      for (int u = 0; u < na; ++u) n += value[u] * field[w.channel * mb + index[u]];
      b.target[w.at] = static_cast<float>(w.pred + n);
    }
  }
  // The sensor readings of the source keyframes (the only ones the DBA uses): the state's
  // inverse depth plus white noise of variance sensor_depth_scale / α (wild: the reading's own
  // residual with a random sign, the readings' energy scaled to that). A draw at or below 0
  // drops the reading, as a sensor without one (the simulator's rule).
  if (s.disps_sens && o.sensor_depth_weight > 0 && cal.sensor_depth_rows > 0) {
    std::vector<float>& ds = *b.disps_sens;
    std::vector<std::size_t> at_reading;  // indices into disps of the sources' readings
    for (int k = 0; k < s.numKeyframes(); ++k) {
      if (std::find(s.ii.begin(), s.ii.end(), k) == s.ii.end()) continue;
      for (int p = 0; p < HW; ++p) {
        const std::size_t at = static_cast<std::size_t>(k) * HW + p;
        if (ds[at] > 0 && s.disps[at] > 0) at_reading.push_back(at);
      }
    }
    const double alpha = o.sensor_depth_weight, white = std::sqrt(cal.sensor_depth_scale / alpha);
    double wild_scale = 0;
    if (wild) {
      double q = 0;
      for (std::size_t at : at_reading) {
        const double r = static_cast<double>(ds[at]) - s.disps[at];
        q += alpha * r * r;
      }
      if (q > 0) wild_scale = std::sqrt(cal.sensor_depth_scale * at_reading.size() / q);
    }
    for (std::size_t at : at_reading) {
      const double r = static_cast<double>(ds[at]) - s.disps[at];
      const double n = wild ? wild_scale * r * (sign(rng) ? 1.0 : -1.0) : white * n01(rng);
      const double draw = s.disps[at] + n;
      ds[at] = draw > 0 ? static_cast<float>(draw) : 0.0f;
    }
  }
  if (!solveDba(b, o, solver).converged()) return {};
  // The replicate's error as the evaluation sees the snapshot's: the "truth" (the snapshot's
  // state) relative to the replicate's estimate, in the replicate's tangent, against the
  // covariance the method reports on the replicate.
  SelfCalibrationOptions nc = opts;
  nc.depth_noise = false;  // the fitted model's own covariance (the bootstrap measures the rest)
  SelfCalibration rc;
  GaugeParameterization gb;
  try {
    rc = selfCalibrate(b, o, nc);
    gb = makeGauge(o.gauge, b, keyframes);
  } catch (const NumericalError&) {
    return {};  // counted as a failed replicate
  }
  if (!rc.fit || rc.fit->reduced_covariance->rows() != gb.dim()) return {};
  Eigen::VectorXd delta(gb.dim());
  for (std::size_t a = 0; a < keyframes.size(); ++a) {
    const int dim = gb.dimOf(static_cast<int>(a));
    if (dim == 0) continue;
    const Vector6d xi = logSE3(b.T_wc(keyframes[a]).inverse() * s.T_wc(keyframes[a]));
    delta.segment(gb.offset[a], dim) = gb.basis[a].colPivHouseholderQr().solve(xi);
  }
  // The joint NEES and each keyframe's marginal NEES.
  const Eigen::MatrixXd& Vb = *rc.fit->reduced_covariance;
  const Eigen::LLT<Eigen::MatrixXd> llt(Vb);
  if (llt.info() != Eigen::Success) return {};
  Eigen::VectorXd out(keyframes.size() + 1);
  out[0] = delta.dot(llt.solve(delta));
  for (std::size_t a = 0; a < keyframes.size(); ++a) {
    const int dim = gb.dimOf(static_cast<int>(a));
    out[a + 1] = 0;
    if (dim == 0) continue;
    const Eigen::VectorXd da = delta.segment(gb.offset[a], dim);
    out[a + 1] = da.dot(Vb.block(gb.offset[a], gb.offset[a], dim, dim).llt().solve(da));
  }
  return out;
}

}  // namespace

void BootstrapOptions::validate() const {
  if (replicates < 4) throw std::invalid_argument("bootstrap replicates must be >= 4");
}

BootstrapCalibration bootstrapSelfCalibration(const Snapshot& s, const DbaOptions& o,
                                              const SelfCalibrationOptions& c,
                                              const BootstrapOptions& bo,
                                              const DbaSolverOptions& solver) {
  c.validate();
  bo.validate();
  solver.validate();
  SelfCalibrationOptions nuisance = c;
  nuisance.depth_noise = false;
  BootstrapCalibration out;
  out.calibration = selfCalibrate(s, o, nuisance);
  SelfCalibration& cal = out.calibration;
  cal.method = "bootstrap";
  const std::vector<int> keyframes = s.graphKeyframes();
  const GaugeParameterization gauge = makeGauge(o.gauge, s, keyframes);
  const int K = gauge.dim();
  if (K == 0 || !cal.fit) return out;
  const Eigen::MatrixXd& V = *cal.fit->reduced_covariance;
  const Eigen::LLT<Eigen::MatrixXd> llt(V);
  if (llt.info() != Eigen::Success || V.rows() != K)
    // (no source prefix here or below: the callers name the snapshot)
    throw NumericalError(
        "the nuisance covariance is not positive definite "
        "(bootstrap self-calibration)",
        keyframes);
  const NuisanceBasis basis{c.nuisance_nodes, s.H, s.W};
  const int R = bo.replicates;
  std::vector<Eigen::VectorXd> delta(R);
  parallelFor(static_cast<std::size_t>(R), [&](std::size_t r) {
    // Each replicate its own stream (splitmix-style spread of the seed).
    const unsigned long long seed = bo.seed * 0x9E3779B97F4A7C15ull + r + 1;
    delta[r] = replicate(s, o, solver, cal, basis, keyframes, nuisance, bo.resampling, seed);
  });
  // Per keyframe (slot a with m_a free coordinates): k_a = Σ_b NEES_b,a / (R m_a), the scale of
  // its marginal; the joint k over all K coordinates for the summary.
  const int n = static_cast<int>(keyframes.size());
  Eigen::VectorXd sum_a = Eigen::VectorXd::Zero(n);
  double sum = 0;
  int ok = 0;
  for (const Eigen::VectorXd& d : delta) {
    if (d.size() != n + 1 || !d.allFinite()) continue;
    ++ok;
    sum += d[0];
    sum_a += d.tail(n);
  }
  out.replicates = ok;
  out.failed = R - ok;
  if (2 * ok < R)
    throw NumericalError("the bootstrap self-calibration's DBA solve converged for " +
                             std::to_string(ok) + " of " + std::to_string(R) + " replicates",
                         keyframes);
  out.scale = sum / (static_cast<double>(ok) * K);
  // V' = D^½ V D^½, D = k_a on slot a's coordinates: each marginal scaled by its own k_a, the
  // correlations kept.
  Eigen::VectorXd root(K);
  out.keyframe_scales.assign(n, 1.0);
  for (int a = 0; a < n; ++a) {
    const int m = gauge.dimOf(a);
    if (m == 0) continue;
    out.keyframe_scales[a] = sum_a[a] / (static_cast<double>(ok) * m);
    root.segment(gauge.offset[a], m).setConstant(std::sqrt(out.keyframe_scales[a]));
  }
  auto fit = std::make_shared<SelfCalibrationFit>(*cal.fit);
  fit->reduced_covariance =
      std::make_shared<const Eigen::MatrixXd>(root.asDiagonal() * V * root.asDiagonal());
  cal.fit = std::move(fit);
  return out;
}

}  // namespace dbacov
