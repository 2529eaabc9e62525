#include "dbacov/app/csv_format.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

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

std::string poseValues(const Eigen::Isometry3d& T) {
  const Eigen::Matrix<double, 7, 1> tq = poseToTQ(T);
  std::string s;
  for (int i = 0; i < 7; ++i) {
    if (i) s += ',';
    s += formatDouble(tq[i]);
  }
  return s;
}

}  // namespace dbacov::app
