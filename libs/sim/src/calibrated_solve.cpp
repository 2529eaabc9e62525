#include "dbacov/sim/calibrated_solve.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dbacov/core/self_calibration.h"

namespace dbacov {

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

  // The ratios only: one vce pass, no depths' term (it changes no variance factor).
  SelfCalibrationOptions ratios;
  ratios.method = SelfCalibrationMethod::Vce;
  ratios.iterations = 1;
  ratios.depth_noise = false;
  const double bound = std::log1p(tolerance);
  const std::size_t plane = 2 * s.pixelsPerFrame();
  for (;;) {
    if (!out.solver.converged()) {
      out.settled = false;
      return out;
    }
    const SelfCalibration cal = selfCalibrate(s, out.options, ratios);
    const double flow =
        cal.global_scale > 0 && std::isfinite(cal.global_scale) ? cal.global_scale : 1.0;
    double worst = 0;
    double sensor = 1;
    if (readings && cal.sensor_depth_rows > 0) {
      sensor = cal.sensor_depth_scale / flow;
      worst = std::max(worst, std::abs(std::log(sensor)));
    }
    std::vector<double> edge(static_cast<std::size_t>(s.numEdges()), 1.0);
    for (const EdgeCalibration& e : cal.edges) {
      if (e.i != e.j || e.rows == 0 || !(e.vce_scale > 0) || !std::isfinite(e.vce_scale)) continue;
      edge[static_cast<std::size_t>(e.edge)] = e.vce_scale / flow;
      worst = std::max(worst, std::abs(std::log(e.vce_scale / flow)));
    }
    out.last_ratio = std::exp(worst);
    if (worst <= bound) return out;
    if (out.solves >= max_solves) {
      out.settled = false;
      return out;
    }
    out.options.sensor_depth_weight /= sensor;
    out.sensor_depth_factor *= sensor;
    for (int e = 0; e < s.numEdges(); ++e) {
      const double f = edge[static_cast<std::size_t>(e)];
      if (f == 1.0) continue;
      out.edge_factors[static_cast<std::size_t>(e)] *= f;
      float* w = &s.weight[static_cast<std::size_t>(e) * plane];
      const float inv = static_cast<float>(1.0 / f);
      for (std::size_t p = 0; p < plane; ++p) w[p] *= inv;
    }
    out.solver = solveDba(s, out.options, solver);
    ++out.solves;
  }
}

}  // namespace dbacov
