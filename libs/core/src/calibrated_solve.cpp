#include "dbacov/core/calibrated_solve.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "dbacov/core/self_calibration.h"
#include "dbacov/core/self_calibration_fit.h"

namespace dbacov {

double DepthOnlyRatios::stereoMedian() const {
  std::vector<double> v;
  for (double r : edge)
    if (r != 1.0) v.push_back(r);
  if (v.empty()) return 1.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

void divideEdgeWeights(Snapshot& s, int edge, double factor) {
  const std::size_t plane = 2 * s.pixelsPerFrame();
  float* w = &s.weight[static_cast<std::size_t>(edge) * plane];
  for (std::size_t p = 0; p < plane; ++p) w[p] = static_cast<float>(w[p] / factor);
}

DepthOnlyRatios depthOnlyRatios(const SelfCalibration& cal, int num_edges) {
  DepthOnlyRatios out;
  out.edge.assign(static_cast<std::size_t>(num_edges), 1.0);
  // The flow's own scale: the stereo edges are not in it (with them, every step towards the
  // ratio falls short by their share of the redundancy).
  double q = 0, redundancy = 0;
  for (const EdgeCalibration& e : cal.edges)
    if (e.i != e.j && e.redundancy > 0.5 && std::isfinite(e.vce_scale)) {
      q += e.vce_scale * e.redundancy;
      redundancy += e.redundancy;
    }
  if (redundancy > 0.5 && q > 0 && std::isfinite(q)) out.flow_scale = q / redundancy;
  if (cal.sensor_depth_rows > 0) {
    if (cal.sensor_depth_redundancy > 0.5 && cal.sensor_depth_scale > 0 &&
        std::isfinite(cal.sensor_depth_scale))
      out.sensor = cal.sensor_depth_scale / out.flow_scale;
    else
      out.readings_unmeasured = true;
  }
  for (const EdgeCalibration& e : cal.edges) {
    if (e.i != e.j || e.rows == 0 || e.edge < 0 || e.edge >= num_edges) continue;
    if (e.redundancy > 0.5 && e.vce_scale > 0 && std::isfinite(e.vce_scale))
      out.edge[static_cast<std::size_t>(e.edge)] = e.vce_scale / out.flow_scale;
    else
      out.unmeasured_edges.push_back(e.edge);
  }
  return out;
}

CalibratedSolve solveDbaAtCalibratedWeights(Snapshot& s, const DbaOptions& o, int max_solves,
                                            double tolerance, const DbaSolverOptions& solver) {
  if (max_solves < 1)
    throw std::invalid_argument("solveDbaAtCalibratedWeights: max_solves must be >= 1");
  if (!(tolerance > 0 && tolerance < 1))
    throw std::invalid_argument("solveDbaAtCalibratedWeights: tolerance must be in (0, 1)");
  CalibratedSolve out;
  out.options = o;
  out.edge_factors.assign(static_cast<std::size_t>(s.numEdges()), 1.0);
  bool stereo = false;
  for (int e = 0; e < s.numEdges(); ++e) stereo |= s.ii[e] == s.jj[e];
  const bool readings = s.disps_sens && o.sensor_depth_weight > 0;
  out.solver = solveDba(s, out.options, solver);
  out.solves = 1;
  if (!stereo && !readings) return out;

  const double bound = std::log1p(tolerance);
  const int E = s.numEdges();
  // Per component (slot E: the readings): the log ratio measured before the last step and that
  // step, for the secant below; NaN = no history (first pass, or an unmeasured step).
  const double none = std::numeric_limits<double>::quiet_NaN();
  const double kMaxLogStep = std::log(1e9);  // no single step beyond 1e9×
  std::vector<double> last_log(static_cast<std::size_t>(E) + 1, none), last_step = last_log;
  // The log step for a measured log ratio l. One pass at the claimed weights' optimum is pulled
  // towards 1 (the flow rows that share the depths absorb part of the misfit): at 4× it measures
  // 3.4–3.8, and grossly over-weighted it saturates (250× measures 5.2 before and after a step
  // of 5.2). After a step the secant gives the share κ = (l_before − l) / step that the pass sees:
  // for κ ≥ 0.2 the step is l / κ (κ at most 2: an overshoot is stepped back by half); below, the
  // measure is saturated and the last step is doubled. Without history the step is l.
  const auto step_for = [&](std::size_t k, double l) {
    double step = l;
    if (std::isfinite(last_log[k]) && std::abs(last_step[k]) > 1e-12) {
      const double kappa = (last_log[k] - l) / last_step[k];
      if (kappa >= 0.2)
        step = l / std::min(kappa, 2.0);
      else if (l * last_step[k] > 0)
        step = std::copysign(std::max(std::abs(l), 2 * std::abs(last_step[k])), l);
    }
    step = std::clamp(step, -kMaxLogStep, kMaxLogStep);
    last_log[k] = l;
    last_step[k] = step;
    return step;
  };
  for (;;) {
    if (!out.solver.converged()) {  // the first solve: nothing to go back to
      out.settled = false;
      return out;
    }
    const DepthOnlyRatios r = depthOnlyRatios(varianceComponents(s, out.options), E);
    // Per component k (the edges, then the readings in slot E): its log ratio; one over-weighted
    // beyond measure gets a fixed step down instead, and measures again after it.
    std::vector<double> steps(static_cast<std::size_t>(E) + 1, 0.0);
    std::vector<bool> measured(steps.size(), true);
    for (int e = 0; e < E; ++e)
      if (s.ii[e] == s.jj[e]) steps[static_cast<std::size_t>(e)] = std::log(r.edge[e]);
    for (int e : r.unmeasured_edges) measured[static_cast<std::size_t>(e)] = false;
    if (readings) {
      steps[static_cast<std::size_t>(E)] = std::log(r.sensor);
      measured[static_cast<std::size_t>(E)] = !r.readings_unmeasured;
    }
    double worst = 0;
    for (std::size_t k = 0; k < steps.size(); ++k) {
      if (!measured[k]) steps[k] = std::log(kUnmeasuredStep);
      worst = std::max(worst, std::abs(steps[k]));
    }
    out.last_ratio = std::exp(worst);
    out.unmeasured = std::find(measured.begin(), measured.end(), false) != measured.end();
    if (worst <= bound) return out;
    if (out.solves >= max_solves) {
      out.settled = false;
      return out;
    }
    for (std::size_t k = 0; k < steps.size(); ++k) {
      if (!measured[k] || steps[k] == 0.0)
        last_log[k] = none;
      else
        steps[k] = step_for(k, steps[k]);
    }
    // A re-solve that does not converge leaves the last converged state and its weights.
    const Snapshot before = s;
    const CalibratedSolve kept = out;
    if (readings) {
      const double f = std::exp(steps[static_cast<std::size_t>(E)]);
      out.options.sensor_depth_weight /= f;
      out.sensor_depth_factor *= f;
    }
    for (int e = 0; e < E; ++e) {
      if (steps[static_cast<std::size_t>(e)] == 0.0) continue;
      const double f = std::exp(steps[static_cast<std::size_t>(e)]);
      out.edge_factors[static_cast<std::size_t>(e)] *= f;
      divideEdgeWeights(s, e, f);
    }
    out.solver = solveDba(s, out.options, solver);
    ++out.solves;
    if (!out.solver.converged()) {
      s = before;
      const int solves = out.solves;
      const DbaSolverSummary failed = out.solver;
      out = kept;
      out.solves = solves;
      out.settled = false;
      out.failed_solve = failed;
      return out;
    }
  }
}

}  // namespace dbacov
