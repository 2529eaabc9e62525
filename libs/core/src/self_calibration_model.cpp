// The self-calibration's dense model of one state and its plain helpers (self_calibration.h,
// self_calibration_stages.h).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

#include "dbacov/core/errors.h"
#include "dbacov/core/marginal_solver.h"
#include "self_calibration_stages.h"

namespace dbacov {

void SelfCalibrationOptions::validate() const {
  if (nuisance_nodes != 0 && !(nuisance_nodes >= 2 && nuisance_nodes <= 8))
    throw std::invalid_argument(
        "self-calibration nuisance nodes must be 0 (affine) or 2..8 (G x G bilinear tents)");
}

std::vector<double> SelfCalibration::inflations() const {
  std::vector<double> c;
  c.reserve(edges.size());
  for (const EdgeCalibration& e : edges) c.push_back(e.inflation);
  return c;
}

Snapshot inflateWeights(const Snapshot& s, const std::vector<double>& inflation) {
  if (static_cast<int>(inflation.size()) != s.numEdges())
    throw std::invalid_argument("inflateWeights: " + std::to_string(inflation.size()) +
                                " inflations for " + std::to_string(s.numEdges()) + " edges");
  Snapshot out = s;
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (int e = 0; e < s.numEdges(); ++e) {
    if (!(inflation[e] > 0) || !std::isfinite(inflation[e]))
      throw std::invalid_argument("inflateWeights: inflation of edge " + std::to_string(e) +
                                  " is not a positive finite number");
    const float f = static_cast<float>(1.0 / inflation[e]);
    float* w = &out.weight[e * plane];
    for (std::size_t p = 0; p < plane; ++p) w[p] *= f;
  }
  return out;
}

OptimumDistance distanceFromOptimum(const Snapshot& s, const DbaOptions& o) {
  o.validate();
  s.validate();
  return selfcal::optimumDistance(selfcal::buildModel(s, o));
}

namespace selfcal {

double clampScale(double x, double lo, double hi) {
  return std::clamp(std::isfinite(x) ? x : hi, lo, hi);
}

DbaOptions sensorCalibratedOptions(const DbaOptions& o, double sensor_scale) {
  DbaOptions out = o;
  if (sensor_scale != 1.0) out.sensor_depth_weight /= sensor_scale;
  return out;
}

DenseModel buildModel(const Snapshot& s, const DbaOptions& o, bool keep_depth_terms) {
  DenseModel m;
  m.ne = linearizeDba(s, o, keep_depth_terms);
  m.gauge = makeGauge(o.gauge, s, m.ne.keyframes);
  checkGaugeReachesAll(m.ne.S, m.gauge, m.ne.keyframes);
  const int n = static_cast<int>(m.ne.keyframes.size()), K = m.gauge.dim();
  m.basis = Eigen::MatrixXd::Zero(6 * n, K);
  for (int a = 0; a < n; ++a)
    if (m.gauge.dimOf(a) > 0)  // (a block of an empty matrix would offset a null pointer)
      m.basis.block(6 * a, m.gauge.offset[a], 6, m.gauge.dimOf(a)) = m.gauge.basis[a];
  m.Sr = Eigen::MatrixXd::Zero(K, K);
  m.Sigma_r = Eigen::MatrixXd::Zero(K, K);
  if (K > 0) {
    const Eigen::MatrixXd upper(reduceSystem(m.ne.S, m.gauge));
    m.Sr = upper.selfadjointView<Eigen::Upper>();
    if (!m.Sr.allFinite())
      throw NumericalError("the information matrix has non-finite entries (self-calibration)", {});
    const Eigen::LLT<Eigen::MatrixXd> llt(m.Sr);
    if (llt.info() != Eigen::Success) {
      // Name the keyframe where it breaks down, as the covariance's own factorization does.
      std::vector<int> kf;
      if (const int col = firstBadPivot(m.Sr); col >= 0)
        kf.push_back(m.ne.keyframes[m.gauge.slotOfColumn(col)]);
      throw NumericalError(
          // (no source prefix: the callers name the snapshot, as for the covariance's own)
          "the reduced information matrix S is not positive definite in the self-calibration" +
              (kf.empty() ? std::string() : " (breakdown at keyframe " + joinKeyframes(kf) + ")") +
              ": some motion is unobservable (degenerate geometry, too few weighted pixels, a "
              "gauge that does not fix every DoF, or a scale fixed only by sensor depths whose "
              "weight is negligible)",
          kf.empty() ? m.ne.keyframes : kf);
    }
    m.L_r = llt.matrixL();
    m.Sigma_r = llt.solve(Eigen::MatrixXd::Identity(K, K));
    m.Sigma_r = 0.5 * (m.Sigma_r + m.Sigma_r.transpose());
  }
  m.Sigma = m.basis * m.Sigma_r * m.basis.transpose();
  return m;
}

OptimumDistance optimumDistance(const DenseModel& m) {
  OptimumDistance d;
  d.free_dof = m.gauge.dim();
  if (m.gauge.dim() == 0) return d;
  const Eigen::VectorXd gr = m.basis.transpose() * m.ne.g_S;
  const Eigen::VectorXd step = m.Sigma_r * gr;
  d.gradient_norm = gr.norm();
  d.step_sigma = std::sqrt(std::max(0.0, gr.dot(step)));
  for (std::size_t a = 0; a + 1 < m.gauge.offset.size(); ++a) {
    const int off = m.gauge.offset[a], dim = m.gauge.dimOf(static_cast<int>(a));
    if (dim == 0) continue;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(m.Sigma_r.block(off, off, dim, dim));
    const Eigen::VectorXd da = step.segment(off, dim);
    d.max_step_sigma = std::max(d.max_step_sigma, std::sqrt(std::max(0.0, da.dot(ldlt.solve(da)))));
  }
  return d;
}

}  // namespace selfcal
}  // namespace dbacov
