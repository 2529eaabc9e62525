#include "dbacov/sim/consistency.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <stdexcept>

#include <Eigen/Eigenvalues>

namespace dbacov {
namespace {

constexpr double kEps = 1e-15;

/// P(a, x) by its power series: e^{−x} x^a / Γ(a+1) · Σ_n x^n / ((a+1)…(a+n)). For x < a + 1.
double gammaPSeries(double a, double x) {
  double term = 1.0, sum = 1.0;
  for (int n = 1; n < 10000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * kEps) break;
  }
  return sum * std::exp(a * std::log(x) - x - std::lgamma(a + 1.0));
}

/// Q(a, x) = 1 − P(a, x) by Legendre's continued fraction
///   Q = e^{−x} x^a / Γ(a) · 1/(x+1−a − 1(1−a)/(x+3−a − 2(2−a)/(x+5−a − …))),
/// evaluated with the modified Lentz method. For x >= a + 1.
double gammaQContinuedFraction(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 10000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kEps) break;
  }
  return std::exp(a * std::log(x) - x - std::lgamma(a)) * h;
}

/// Standard normal quantile by Newton's method on Φ(z) = erfc(−z/√2)/2 from z = 0 (Φ is concave
/// for z > 0 and convex for z < 0, so the iterates approach the root monotonically).
double normalQuantile(double p) {
  double z = 0.0;
  for (int it = 0; it < 100; ++it) {
    const double F = 0.5 * std::erfc(-z / std::sqrt(2.0));
    const double f = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
    const double dz = (F - p) / f;
    z -= dz;
    if (std::abs(dz) < 1e-14 * (1.0 + std::abs(z))) break;
  }
  return z;
}

/// Ranks 1..n, ties averaged.
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> idx(v.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < idx.size();) {
    std::size_t j = i;
    while (j + 1 < idx.size() && v[idx[j + 1]] == v[idx[i]]) ++j;
    const double avg = 0.5 * static_cast<double>(i + j) + 1.0;
    for (std::size_t q = i; q <= j; ++q) r[idx[q]] = avg;
    i = j + 1;
  }
  return r;
}

}  // namespace

double regularizedGammaP(double a, double x) {
  if (!(a > 0) || !(x >= 0)) throw std::invalid_argument("regularizedGammaP: need a > 0, x >= 0");
  if (x == 0) return 0.0;
  if (std::isinf(x)) return 1.0;
  return x < a + 1.0 ? gammaPSeries(a, x) : 1.0 - gammaQContinuedFraction(a, x);
}

double chiSquareCdf(double x, double k) {
  if (!(k > 0)) throw std::invalid_argument("chiSquareCdf: need k > 0");
  return x <= 0 ? 0.0 : regularizedGammaP(0.5 * k, 0.5 * x);
}

double chiSquareQuantile(double p, double k) {
  if (!(p > 0 && p < 1) || !(k > 0 && std::isfinite(k)))
    throw std::invalid_argument("chiSquareQuantile: need 0 < p < 1 and k > 0");
  // Wilson–Hilferty: (X/k)^(1/3) is nearly normal with mean 1 − 2/(9k) and variance 2/(9k).
  const double v = 2.0 / (9.0 * k);
  double x = k * std::pow(std::max(1.0 - v + normalQuantile(p) * std::sqrt(v), 1e-3), 3);
  // Bracket the root, then Newton steps that fall back to bisection when they leave the bracket.
  double lo = 0.0, hi = std::max(x, 1.0);
  while (chiSquareCdf(hi, k) < p) hi *= 2.0;
  const double log_norm = 0.5 * k * std::log(2.0) + std::lgamma(0.5 * k);
  for (int it = 0; it < 200; ++it) {
    const double F = chiSquareCdf(x, k) - p;
    if (F < 0)
      lo = x;
    else
      hi = x;
    const double pdf = std::exp((0.5 * k - 1.0) * std::log(x) - 0.5 * x - log_norm);
    double next = pdf > 0 ? x - F / pdf : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const bool done = std::abs(next - x) <= 1e-13 * x || hi - lo <= 1e-13 * hi;
    x = next;
    if (done) break;
  }
  return x;
}

ChiSquareRegion aneesRegion(double dof, int runs, double alpha) {
  if (!(dof > 0) || runs < 1 || !(alpha > 0 && alpha < 1))
    throw std::invalid_argument("aneesRegion: need dof > 0, runs >= 1, 0 < alpha < 1");
  const double k = dof * runs;
  return {chiSquareQuantile(0.5 * alpha, k) / runs, chiSquareQuantile(1.0 - 0.5 * alpha, k) / runs};
}

Vector6d poseError(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_true) {
  return logSE3(T_est.inverse() * T_true);
}

Nees computeNees(const Vector6d& e, const Matrix6d& Sigma) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (Sigma + Sigma.transpose()));
  const Vector6d lambda = es.eigenvalues();
  const double lmax = lambda.maxCoeff();
  Nees n;
  if (!(lmax > 0)) return n;
  const Vector6d proj = es.eigenvectors().transpose() * e;
  for (int i = 0; i < 6; ++i)
    if (lambda[i] > 1e-12 * lmax) {
      n.value += proj[i] * proj[i] / lambda[i];
      ++n.dof;
    }
  return n;
}

NeesSample makeSample(std::int64_t run, std::string group, const Vector6d& e,
                      const Matrix6d& Sigma) {
  NeesSample s;
  s.run = run;
  s.group = std::move(group);
  s.e = e;
  s.Sigma = Sigma;
  s.nees = computeNees(e, Sigma);
  return s;
}

double spearmanCorrelation(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size() || x.size() < 2)
    throw std::invalid_argument("spearmanCorrelation: need two samples of equal size >= 2");
  const std::vector<double> rx = ranks(x), ry = ranks(y);
  const double n = static_cast<double>(x.size()), mean = 0.5 * (n + 1.0);
  double sxy = 0, sxx = 0, syy = 0;
  for (std::size_t i = 0; i < rx.size(); ++i) {
    sxy += (rx[i] - mean) * (ry[i] - mean);
    sxx += (rx[i] - mean) * (rx[i] - mean);
    syy += (ry[i] - mean) * (ry[i] - mean);
  }
  return sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
}

std::array<double, 3> nominalCoverage() {
  return {std::erf(1.0 / std::sqrt(2.0)), std::erf(2.0 / std::sqrt(2.0)),
          std::erf(3.0 / std::sqrt(2.0))};
}

ConsistencyStats summarize(const std::vector<NeesSample>& all, double alpha) {
  std::vector<const NeesSample*> s;
  for (const NeesSample& x : all)
    if (x.nees.dof > 0) s.push_back(&x);
  if (s.empty()) throw std::invalid_argument("summarize: no sample with a non-singular covariance");
  ConsistencyStats st;
  st.samples = s.size();
  std::set<std::int64_t> runs;
  double sum_nees = 0, sum_dof = 0;
  Eigen::Matrix<double, 6, 3> hits = Eigen::Matrix<double, 6, 3>::Zero();
  Vector6d counted = Vector6d::Zero();
  std::vector<double> pt, et, pr, er;
  std::size_t above = 0;
  for (const NeesSample* x : s) {
    runs.insert(x->run);
    sum_nees += x->nees.value;
    sum_dof += x->nees.dof;
    above += x->nees.value > chiSquareQuantile(0.95, x->nees.dof);
    const double smax = x->Sigma.diagonal().maxCoeff();
    for (int i = 0; i < 6; ++i) {
      const double var = x->Sigma(i, i);
      if (!(var > 1e-12 * smax)) continue;
      counted[i] += 1;
      for (int m = 1; m <= 3; ++m) hits(i, m - 1) += std::abs(x->e[i]) <= m * std::sqrt(var);
    }
    pt.push_back(std::sqrt(std::max(0.0, x->Sigma.topLeftCorner<3, 3>().trace())));
    et.push_back(x->e.head<3>().norm());
    pr.push_back(std::sqrt(std::max(0.0, x->Sigma.bottomRightCorner<3, 3>().trace())));
    er.push_back(x->e.tail<3>().norm());
  }
  st.runs = static_cast<int>(runs.size());
  st.anees = sum_nees / st.samples;
  st.dof = sum_dof / st.samples;
  st.region = aneesRegion(st.dof, st.runs, alpha);
  st.inside = st.region.contains(st.anees);
  st.tail_95 = static_cast<double>(above) / st.samples;
  for (int i = 0; i < 6; ++i)
    if (counted[i] > 0) st.coverage.row(i) = hits.row(i) / counted[i];
  for (int m = 0; m < 3; ++m)
    st.coverage_all[m] = counted.sum() > 0 ? hits.col(m).sum() / counted.sum() : 0.0;
  if (s.size() >= 3) {
    st.spearman_translation = spearmanCorrelation(pt, et);
    st.spearman_rotation = spearmanCorrelation(pr, er);
  }
  return st;
}

double fitInflation(const std::vector<NeesSample>& samples) {
  double sum_nees = 0, sum_dof = 0;
  for (const NeesSample& x : samples)
    if (x.nees.dof > 0) {
      sum_nees += x.nees.value;
      sum_dof += x.nees.dof;
    }
  if (!(sum_dof > 0))
    throw std::invalid_argument("fitInflation: no sample with a non-singular covariance");
  return sum_nees / sum_dof;
}

std::vector<NeesSample> inflate(std::vector<NeesSample> samples, double k) {
  if (!(k > 0 && std::isfinite(k)))
    throw std::invalid_argument("inflate: k must be finite and > 0");
  for (NeesSample& x : samples) {
    x.Sigma *= k;
    x.nees.value /= k;
  }
  return samples;
}

}  // namespace dbacov
