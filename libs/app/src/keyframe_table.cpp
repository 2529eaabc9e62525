#include "dbacov/app/keyframe_table.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "dbacov/core/criteria.h"

namespace dbacov::app {

std::string formatDouble(double v) {
  if (std::isnan(v)) throw std::logic_error("formatDouble: NaN must not reach an output file");
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (v == 0) v = 0.0;  // no "-0"
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string upperTriangleNames(const std::string& prefix) {
  std::string s;
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) {
      if (!s.empty()) s += ',';
      s += prefix + std::to_string(r) + std::to_string(c);
    }
  return s;
}

std::string upperTriangleValues(const Matrix6d& M) {
  std::string s;
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) {
      if (!s.empty()) s += ',';
      s += formatDouble(M(r, c));
    }
  return s;
}

std::string keyframeCsvHeader() {
  return "snapshot,keyframe,tstamp,tx,ty,tz,qx,qy,qz,qw,log10_det,d_opt,a_opt,e_opt,log10_det_rot,"
         "log10_det_trans," +
         upperTriangleNames("cov_");
}

void writeKeyframeRows(std::ostream& os, const Snapshot& s, const DbaCovariance& cov) {
  for (int k : cov.keyframes()) {
    const Matrix6d Sigma = cov.marginal(k);
    const UncertaintyCriteria c = computeCriteria(Sigma);
    const Eigen::Matrix<double, 7, 1> tq = poseToTQ(cov.T_wc(k));
    os << s.label() << ',' << k << ',' << formatDouble(s.tstamp[k]);
    for (int i = 0; i < 7; ++i) os << ',' << formatDouble(tq[i]);
    for (double v : {c.log10_det, c.d_opt, c.a_opt, c.e_opt, c.log10_det_rot, c.log10_det_trans})
      os << ',' << formatDouble(v);
    os << ',' << upperTriangleValues(Sigma) << '\n';
  }
}

}  // namespace dbacov::app
