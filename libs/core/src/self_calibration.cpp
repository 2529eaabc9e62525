// Self-calibration from the residuals (self_calibration.h): the dense model of the snapshot's
// state, one pass over every edge's residuals (edge_pass.cpp), the nuisance model's fit
// (nuisance_fit.cpp), and the covariance with the depths' second-order term. The pose covariance
// the stages need is dense (K×K in the gauge's reduced coordinates, K = free pose DoF), which is
// cheap for DROID-sized windows.
#include "dbacov/core/self_calibration.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "dbacov/core/depth_noise.h"
#include "dbacov/core/given_model.h"
#include "dbacov/core/self_calibration_fit.h"
#include "self_calibration_stages.h"

namespace dbacov {

namespace {

using selfcal::DenseModel;
using selfcal::EdgeAccum;

/// The calibration's per-edge record and the pooled scales of one pass.
SelfCalibration newCalibration(const Snapshot& s) {
  SelfCalibration out;
  const int E = s.numEdges();
  out.edges.resize(E);
  for (int e = 0; e < E; ++e) {
    out.edges[e].edge = e;
    out.edges[e].i = static_cast<int>(s.ii[e]);
    out.edges[e].j = static_cast<int>(s.jj[e]);
  }
  return out;
}

/// Each edge's white-noise sums (redundancy, q / redundancy) and the snapshot's pooled scale.
void recordEdges(const std::vector<EdgeAccum>& acc, SelfCalibration& out) {
  const selfcal::Pooled edges = selfcal::pooled(acc);
  out.global_scale = edges.redundancy > 0 ? edges.q / edges.redundancy : 1.0;
  for (std::size_t e = 0; e < acc.size(); ++e) {
    const EdgeAccum& a = acc[e];
    EdgeCalibration& ec = out.edges[e];
    ec.pixels = a.pixels;
    ec.rows = a.rows;
    ec.residual_rms = a.rows ? std::sqrt(a.sum_r2 / a.rows) : 0.0;
    ec.chi2 = a.q;
    ec.redundancy = a.rows - a.lev;
    // Without redundancy (no used rows, or everything absorbed) the edge keeps its factor.
    ec.vce_scale = ec.redundancy > 0.5 ? a.q / ec.redundancy : 1.0;
    ec.effective_pixels = static_cast<double>(ec.pixels);
  }
}

/// The largest share ρ of a direction's information the depths' noise may take before the
/// second-order expansion is held (depthNoiseCovariance).
constexpr double kMaxDepthShare = 0.9;

/// The depths' second-order term (depth_noise.h) of the white noise each edge was found to have,
/// in the gauge's reduced coordinates, and what it reports into `summary`.
Eigen::MatrixXd depthNoiseTerm(const Snapshot& s, const DbaOptions& oc, const SelfCalibration& cal,
                               const Eigen::MatrixXd& V, SelfCalibrationSummary& summary) {
  Snapshot si = inflateWeights(s, cal.inflations());
  DenseModel m = selfcal::buildModel(si, oc, true);
  const DepthNoiseTerms dn = depthNoiseTerms(si, oc, m.ne, cal.depth_noise_kurtosis);
  const Eigen::MatrixXd Mr = m.basis.transpose() * dn.M * m.basis;
  Eigen::MatrixXd Nr = m.basis.transpose() * dn.N * m.basis;
  // The variance's fourth-cumulant share (heavy tails: each row's, and the two axes' of a factor
  // jointly; depth_noise.h): in M + N only, H keeps the Gaussian M.
  Eigen::MatrixXd Mv = Mr;
  if (cal.depth_noise_kurtosis) {
    Mv += m.basis.transpose() * dn.M_kurtosis * m.basis;
    Nr += m.basis.transpose() * dn.N_kurtosis * m.basis;
  }
  // The information at the true depths, H = E[S(d̂)] − M, inverted; the score's variance
  // S + M + N around it (a sandwich). In S's whitened coordinates L⁻¹ M L⁻ᵀ = Q diag(ρ) Qᵀ
  // (ρ: the share of a direction's information the depths' noise takes) and
  // H⁻¹ = L⁻ᵀ Q diag(1/(1 − ρ)) Qᵀ L⁻¹ (L: buildModel's Cholesky factor of S). The expansion is
  // second order: beyond ρ = kMaxDepthShare it is not trusted and 1/(1 − ρ) is held at 10,
  // continuously (a switch to the first-order inverse where S − M stops being positive definite
  // made the covariance blow up just before it and drop at it; a cap at ½ made the white-3×
  // Monte Carlo over-confident, docs/studies/depth-noise.md).
  const Eigen::MatrixXd Li = m.L_r.triangularView<Eigen::Lower>().solve(
      Eigen::MatrixXd::Identity(m.Sr.rows(), m.Sr.cols()));  // L⁻¹
  Eigen::MatrixXd W = Li * Mr * Li.transpose();
  W = 0.5 * (W + W.transpose()).eval();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(W);
  const Eigen::VectorXd f = es.eigenvalues().unaryExpr(
      [](double rho) { return 1.0 / (1.0 - std::clamp(rho, 0.0, kMaxDepthShare)); });
  const Eigen::MatrixXd QtLi = es.eigenvectors().transpose() * Li;
  const Eigen::MatrixXd Sigma1 = QtLi.transpose() * f.asDiagonal() * QtLi;
  if (es.eigenvalues().size() > 0) summary.depth_noise_max_rho = es.eigenvalues().maxCoeff();
  const Eigen::MatrixXd term = Sigma1 + Sigma1 * (Mv + Nr) * Sigma1 - m.Sigma_r;
  if (V.trace() > 0) summary.depth_noise_share = term.trace() / V.trace();
  summary.depth_noise_kurtosis = cal.depth_noise_kurtosis ? dn.kurtosis : 0.0;
  summary.depth_noise_cross_kurtosis = cal.depth_noise_kurtosis ? dn.cross_kurtosis : 0.0;
  return term;
}

}  // namespace

SelfCalibration selfCalibrate(const Snapshot& s, const DbaOptions& o,
                              const SelfCalibrationOptions& c) {
  o.validate();
  c.validate();
  s.validate();
  SelfCalibration out = newCalibration(s);
  out.depth_noise = c.depth_noise;
  out.depth_noise_kurtosis = c.depth_noise_kurtosis;
  const NuisanceBasis basis{c.nuisance_nodes, s.H, s.W};
  DenseModel model = selfcal::buildModel(s, o);
  out.passes = 1;
  // The gauge holds every pose: every covariance is 0 whatever the noise, and there is no free
  // direction for the residuals to calibrate (selfCalibratedCovariance: the engine's).
  if (model.gauge.dim() == 0) return out;
  std::vector<selfcal::SourceTerms> sources;
  std::vector<EdgeAccum> sensor;
  const std::vector<EdgeAccum> acc = selfcal::edgePass(s, o, model, &basis, &sources, &sensor);
  out.optimum = selfcal::optimumDistance(model);
  recordEdges(acc, out);
  // The white scales' bounds, relative to the pooled scale: the same answer whatever weight scale
  // the snapshot claims (without residuals to pool, the claimed scale).
  const double ref = out.global_scale > 0 && std::isfinite(out.global_scale) ? out.global_scale : 1;
  const double lo = ref / selfcal::kScaleRange, hi = ref * selfcal::kScaleRange;
  // The sensor readings' variance component, one for all sources (DROID's α is one number):
  // Σ q / Σ redundancy.
  const selfcal::Pooled readings = selfcal::pooled(sensor);
  out.sensor_depth_rows = static_cast<std::size_t>(readings.rows);
  out.sensor_depth_redundancy = readings.redundancy;
  if (readings.redundancy > 0.5)
    out.sensor_depth_scale = selfcal::clampScale(readings.q / readings.redundancy, lo, hi);
  auto fit = std::make_shared<SelfCalibrationFit>();
  fit->reduced_covariance = std::make_shared<const Eigen::MatrixXd>(selfcal::nuisanceCovariance(
      model, acc, sources, sensor, out.sensor_depth_scale, basis.groups(), lo, hi, &out));
  fit->linearization = std::make_shared<const DbaNormalEquations>(std::move(model.ne));
  out.fit = std::move(fit);
  out.nuisance_params = 2 * basis.perChannel();
  return out;
}

SelfCalibration varianceComponents(const Snapshot& s, const DbaOptions& o) {
  o.validate();
  s.validate();
  SelfCalibration out = newCalibration(s);
  out.method = "vce";
  const DenseModel model = selfcal::buildModel(s, o);
  out.passes = 1;
  if (model.gauge.dim() == 0) return out;
  std::vector<EdgeAccum> sensor;
  const std::vector<EdgeAccum> acc = selfcal::edgePass(s, o, model, nullptr, nullptr, &sensor);
  out.optimum = selfcal::optimumDistance(model);
  recordEdges(acc, out);
  for (EdgeCalibration& ec : out.edges) ec.inflation = ec.vce_scale;
  const selfcal::Pooled readings = selfcal::pooled(sensor);
  out.sensor_depth_rows = static_cast<std::size_t>(readings.rows);
  out.sensor_depth_redundancy = readings.redundancy;
  if (readings.redundancy > 0.5) out.sensor_depth_scale = readings.q / readings.redundancy;
  return out;
}

DbaCovariance selfCalibratedCovariance(const Snapshot& s, const DbaOptions& o,
                                       const CovarianceOptions& solver,
                                       const SelfCalibration& cal) {
  if (static_cast<int>(cal.edges.size()) != s.numEdges())
    throw std::invalid_argument(s.source + ": the self-calibration has " +
                                std::to_string(cal.edges.size()) + " edges, the snapshot " +
                                std::to_string(s.numEdges()) + ": it is of another snapshot");
  for (int e = 0; e < s.numEdges(); ++e)
    if (cal.edges[e].i != s.ii[e] || cal.edges[e].j != s.jj[e])
      throw std::invalid_argument(
          s.source + ": edge " + std::to_string(e) + " is (" + std::to_string(s.ii[e]) + ", " +
          std::to_string(s.jj[e]) + "), the self-calibration's (" + std::to_string(cal.edges[e].i) +
          ", " + std::to_string(cal.edges[e].j) + "): it is of another snapshot");
  detail::GivenModel given;
  given.calibration.method = cal.method;
  given.calibration.edge_factor = cal.inflations();
  given.calibration.sensor_depth_scale = cal.sensor_depth_scale;
  if (!cal.fit) {
    if (cal.passes == 0 || cal.optimum.free_dof != 0)
      throw std::invalid_argument(s.source + ": the self-calibration holds no fitted model");
    return given.build(s, o, solver);  // the gauge holds every pose: all 0
  }
  given.linearization = cal.fit->linearization;
  given.reduced_covariance = cal.fit->reduced_covariance;
  if (cal.depth_noise) {
    // The sensor readings' information at their fitted scale, wherever the model is rebuilt.
    const DbaOptions oc = selfcal::sensorCalibratedOptions(o, cal.sensor_depth_scale);
    const Eigen::MatrixXd& V = *cal.fit->reduced_covariance;
    Eigen::MatrixXd Vd = V + depthNoiseTerm(s, oc, cal, V, given.calibration);
    Vd = 0.5 * (Vd + Vd.transpose()).eval();
    given.reduced_covariance = std::make_shared<const Eigen::MatrixXd>(std::move(Vd));
  }
  given.calibration.checkFit();
  return given.build(s, o, solver);
}

}  // namespace dbacov
