#include "dbacov/core/summary.h"

#include <vector>

#include <cmath>

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace dbacov {
namespace {

std::string milliseconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f ms", 1e3 * s);
  return buf;
}

std::string factorRange(const std::vector<double>& f) {
  if (f.empty()) return "none";
  std::vector<double> v = f;
  std::sort(v.begin(), v.end());
  char buf[96];
  std::snprintf(buf, sizeof buf, "min %.3g, median %.3g, max %.3g", v.front(), v[v.size() / 2],
                v.back());
  return buf;
}

}  // namespace

std::string CovarianceSummary::brief() const {
  std::ostringstream os;
  os << keyframes << " keyframes, " << edges << " edges, " << linearization.factors_used
     << " pixel factors, " << solver;
  if (solver == "cholmod") os << " (" << ordering << ")";
  os << " nnz(L) " << factor_entries << ", "
     << milliseconds(seconds_linearize + seconds_gauge + seconds_factorize);
  if (!self_calibration.method.empty())
    os << ", self-calibrated (" << self_calibration.method << ")";
  return os.str();
}

std::string CovarianceSummary::full() const {
  std::ostringstream os;
  os << "keyframes                " << keyframes << '\n'
     << "edges                    " << edges << '\n'
     << "pixel factors used       " << linearization.factors_used << '\n'
     << "pixel factors filtered   " << linearization.factors_filtered << '\n'
     << "depths eliminated        " << linearization.depths_used << '\n'
     << "depths unobservable      " << linearization.depths_unobservable << '\n'
     << "chi2 (weighted)          " << linearization.chi2 << '\n'
     << "free DoF after gauge     " << free_dof << '\n'
     << "solver                   " << solver << '\n'
     << "ordering                 " << ordering << '\n'
     << "nnz(L)                   " << factor_entries << '\n'
     << "linearize + Schur        " << milliseconds(seconds_linearize) << '\n'
     << "gauge + reduction        " << milliseconds(seconds_gauge) << '\n'
     << "factorization            " << milliseconds(seconds_factorize) << '\n'
     << "self-calibration         "
     << (self_calibration.method.empty() ? std::string("none") : self_calibration.method) << '\n';
  if (!self_calibration.method.empty())
    os << "edge variance factors    " << factorRange(self_calibration.edge_factor) << '\n';
  if (self_calibration.sensor_depth_scale != 1.0)
    os << "sensor depths' factor    " << self_calibration.sensor_depth_scale
       << " (variance; their information alpha / factor)\n";
  if (self_calibration.depth_noise_share > 0)
    os << "depths' 2nd-order term   +" << 100 * self_calibration.depth_noise_share
       << " % on the calibrated trace (residual excess kurtosis "
       << self_calibration.depth_noise_kurtosis << ", joint across the flow axes "
       << self_calibration.depth_noise_cross_kurtosis << ", largest depth share of a direction "
       << self_calibration.depth_noise_max_rho << ")\n";
  if (!self_calibration.method.empty())
    os << "noise-model fit          "
       << (self_calibration.poor_fit ? "poor (sigmas are a lower bound)" : "no sign of misfit")
       << ": edge white-scale spread " << self_calibration.edge_scale_spread << " (log sd; limit "
       << kPoorFitScaleSpread << "), residual excess kurtosis "
       << self_calibration.depth_noise_kurtosis << " (limit " << kPoorFitKurtosis << ")\n";
  return os.str();
}

void SelfCalibrationSummary::checkFit() {
  std::vector<double> logs;
  for (double f : edge_factor)
    if (f > 0 && std::isfinite(f)) logs.push_back(std::log(f));
  edge_scale_spread = 0;
  if (logs.size() >= 4) {
    const auto at = [&logs](double q) {
      const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(logs.size() - 1));
      std::nth_element(logs.begin(), logs.begin() + static_cast<std::ptrdiff_t>(k), logs.end());
      return logs[k];
    };
    edge_scale_spread = (at(0.75) - at(0.25)) / 1.349;
  }
  poor_fit = edge_scale_spread > kPoorFitScaleSpread || depth_noise_kurtosis > kPoorFitKurtosis;
}

}  // namespace dbacov
