#include "dbacov/core/dba_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "dbacov/core/gauge.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/marginal_solver.h"
#include "dbacov/core/se3.h"

namespace dbacov {
namespace {

/// A soft two-pose prior, centred on the pose the solve started from.
struct Prior {
  int slot = -1;
  Eigen::Isometry3d T0;
  Eigen::MatrixXd P;  ///< information in the gauge's reduced coordinates (makeGauge's prior)
};

/// Everything one iteration needs at one state.
struct Linearization {
  DbaNormalEquations ne;
  GaugeParameterization gauge;  ///< prior[a] replaced by the prior's Gauss-Newton block JᵀPJ
  std::vector<Eigen::VectorXd> prior_grad;  ///< per slot, reduced (empty without a prior)
  /// Per DepthTerms entry and depth: at the bound min_inverse_depth with a gradient that pushes it
  /// further down. Active depths are held (δd = 0) and not eliminated.
  std::vector<std::vector<char>> active;
  double cost = 0;
  double gradient = 0;  ///< max |g| over reduced pose coordinates and depths (undamped)
};

std::vector<Prior> makePriors(const Snapshot& s, const GaugeParameterization& g,
                              const std::vector<int>& keyframes) {
  std::vector<Prior> priors;
  for (int a : g.gauge_slots)
    if (g.prior[a].size()) priors.push_back({a, s.T_wc(keyframes[a]), g.prior[a]});
  return priors;
}

Linearization linearize(const Snapshot& s, const DbaOptions& o, const std::vector<Prior>& priors,
                        double min_d) {
  Linearization L;
  L.ne = linearizeDba(s, o, /*keep_depth_terms=*/true);
  L.gauge = makeGauge(o.gauge, s, L.ne.keyframes);
  L.cost = 0.5 * L.ne.stats.chi2;
  const int n = static_cast<int>(L.ne.keyframes.size());
  L.prior_grad.assign(n, Eigen::VectorXd());
  for (const Prior& p : priors) {
    // e = Log(T0⁻¹ T Exp(δ)) ≈ e + Jr(e)⁻¹ δ (se3.h); in reduced coordinates e_r = Bᵀ e,
    // J = Bᵀ Jr⁻¹ B. The priors only ever see small deviations, where Jr is well conditioned.
    const Eigen::MatrixXd& B = L.gauge.basis[p.slot];
    const Vector6d e = logSE3(p.T0.inverse() * s.T_wc(L.ne.keyframes[p.slot]));
    const Eigen::MatrixXd J = B.transpose() * rightJacobianSE3(e).inverse() * B;
    const Eigen::VectorXd e_r = B.transpose() * e;
    L.cost += 0.5 * e_r.dot(p.P * e_r);
    L.gauge.prior[p.slot] = J.transpose() * p.P * J;
    L.prior_grad[p.slot] = J.transpose() * (p.P * e_r);
  }
  for (int a = 0; a < n; ++a) {
    if (L.gauge.dimOf(a) == 0) continue;
    Eigen::VectorXd g = L.gauge.basis[a].transpose() * L.ne.g_p.segment<6>(6 * a);
    if (L.prior_grad[a].size()) g += L.prior_grad[a];
    L.gradient = std::max(L.gradient, g.cwiseAbs().maxCoeff());
  }
  // Bound constraint d >= min_d: a depth at the bound whose gradient points down (g_k > 0 means
  // the cost falls as d falls) is active; the projected gradient ignores it.
  const std::size_t HW = s.pixelsPerFrame();
  const float bound = static_cast<float>(min_d);
  for (const DepthTerms& dt : L.ne.depths) {
    const float* d = &s.disps[static_cast<std::size_t>(L.ne.keyframes[dt.source_slot]) * HW];
    std::vector<char> act(dt.g.size(), 0);
    for (std::size_t k = 0; k < dt.g.size(); ++k) {
      act[k] = min_d > 0 && d[dt.pixel[k]] <= bound && dt.g[k] > 0;
      if (!act[k]) L.gradient = std::max(L.gradient, std::abs(dt.g[k]));
    }
    L.active.push_back(std::move(act));
  }
  return L;
}

struct Step {
  Eigen::VectorXd xi;               ///< 6 per slot
  std::vector<Eigen::VectorXd> dd;  ///< per DepthTerms entry, one per kept depth
  double predicted = 0;
};

/// Steps 2–4 of the header. Throws FactorizationError when the damped system is not PD.
Step dampedStep(const Linearization& L, double lambda, Ordering ordering) {
  const DbaNormalEquations& ne = L.ne;
  const int n = static_cast<int>(ne.keyframes.size());
  const double c = lambda / (1.0 + lambda);

  // S_λ = (1 − c) S + c Hpp + λ diag(Hpp),  g_λ = (1 − c) g_S + c g_p.
  BlockSymmetricMatrix S_l(n);
  for (int a = 0; a < n; ++a) {
    S_l.at(a, a);
    for (const auto& [b, M] : ne.S.row(a)) S_l.at(a, b) += (1.0 - c) * M;
    for (const auto& [b, M] : ne.Hpp.row(a)) S_l.at(a, b) += c * M;
    if (const Matrix6d* D = ne.Hpp.find(a, a)) S_l.at(a, a).diagonal() += lambda * D->diagonal();
  }
  Eigen::VectorXd g_l = (1.0 - c) * ne.g_S + c * ne.g_p;
  // Active depths are held: undo their elimination, b_k b_kᵀ / ((1+λ) h_k) and b_k g_k / ((1+λ)
  // h_k).
  for (std::size_t t = 0; t < ne.depths.size(); ++t) {
    const DepthTerms& dt = ne.depths[t];
    for (std::size_t k = 0; k < dt.h.size(); ++k) {
      if (!L.active[t][k]) continue;
      const double inv = 1.0 / ((1.0 + lambda) * dt.h[k]);
      const Eigen::VectorXd b = dt.B.col(k);
      for (std::size_t p = 0; p < dt.touched.size(); ++p) {
        g_l.segment<6>(6 * dt.touched[p]) += inv * dt.g[k] * b.segment<6>(6 * p);
        for (std::size_t q = 0; q < dt.touched.size(); ++q)
          if (dt.touched[p] <= dt.touched[q])
            S_l.at(dt.touched[p], dt.touched[q]) +=
                inv * b.segment<6>(6 * p) * b.segment<6>(6 * q).transpose();
      }
    }
  }

  GaugeParameterization gauge = L.gauge;  // priors damped the same way: M + λ diag(M)
  for (auto& M : gauge.prior)
    if (M.size()) M.diagonal() *= 1.0 + lambda;
  Eigen::VectorXd g_r(gauge.dim());
  for (int a = 0; a < n; ++a) {
    if (gauge.dimOf(a) == 0) continue;
    Eigen::VectorXd g = gauge.basis[a].transpose() * g_l.segment<6>(6 * a);
    if (L.prior_grad[a].size()) g += L.prior_grad[a];
    g_r.segment(gauge.offset[a], gauge.dimOf(a)) = g;
  }
  Step st;
  st.xi = Eigen::VectorXd::Zero(6 * n);
  double gTd = 0, dDd = 0;  // gᵀδ and δᵀ diag(H) δ of the undamped full system
  if (gauge.dim() > 0) {
    auto solver = makeCholmodMarginalSolver(ordering);
    solver->factorize(reduceSystem(S_l, gauge));
    const Eigen::VectorXd x = -solver->solve(g_r);
    for (int a = 0; a < n; ++a) {
      const int m = gauge.dimOf(a);
      if (m == 0) continue;
      const Eigen::VectorXd x_a = x.segment(gauge.offset[a], m);
      st.xi.segment<6>(6 * a) = gauge.basis[a] * x_a;
      gTd += ne.g_p.segment<6>(6 * a).dot(st.xi.segment<6>(6 * a));
      if (const Matrix6d* D = ne.Hpp.find(a, a))
        dDd += st.xi.segment<6>(6 * a).cwiseAbs2().dot(D->diagonal());
      if (L.prior_grad[a].size()) {
        gTd += L.prior_grad[a].dot(x_a);
        dDd += x_a.cwiseAbs2().dot(L.gauge.prior[a].diagonal());
      }
    }
  }
  // δd_k = −(g_k + b_kᵀ δp) / ((1 + λ) h_k) over the slots that depth k touches.
  for (std::size_t t = 0; t < ne.depths.size(); ++t) {
    const DepthTerms& dt = ne.depths[t];
    Eigen::VectorXd dp(6 * dt.touched.size());
    for (std::size_t q = 0; q < dt.touched.size(); ++q)
      dp.segment<6>(6 * q) = st.xi.segment<6>(6 * dt.touched[q]);
    const Eigen::VectorXd bTdp = dt.B.transpose() * dp;
    Eigen::VectorXd dd(dt.h.size());
    for (std::size_t k = 0; k < dt.h.size(); ++k) {
      if (L.active[t][k]) {
        dd[k] = 0;
        continue;
      }
      dd[k] = -(dt.g[k] + bTdp[k]) / ((1.0 + lambda) * dt.h[k]);
      gTd += dt.g[k] * dd[k];
      dDd += dt.h[k] * dd[k] * dd[k];
    }
    st.dd.push_back(std::move(dd));
  }
  // With (Pᵀ H_λ P) x = −Pᵀ g and δ = P x: δᵀHδ = −gᵀδ − λ δᵀDδ, so the model decrease
  // −gᵀδ − ½ δᵀHδ is ½ (λ δᵀDδ − gᵀδ).
  st.predicted = 0.5 * (lambda * dDd - gTd);
  return st;
}

/// Applies a step to the state; returns the number of clamped inverse depths.
std::size_t applyStep(Snapshot& s, const DbaNormalEquations& ne, const Step& st, double min_d) {
  for (std::size_t a = 0; a < ne.keyframes.size(); ++a) {
    const Vector6d xi = st.xi.segment<6>(6 * a);
    if (xi.isZero(0)) continue;  // fixed keyframes stay bit-identical
    const int k = ne.keyframes[a];
    s.setT_wc(k, s.T_wc(k) * expSE3(xi));
  }
  std::size_t clamped = 0;
  const std::size_t HW = s.pixelsPerFrame();
  for (std::size_t t = 0; t < ne.depths.size(); ++t) {
    const DepthTerms& dt = ne.depths[t];
    float* d = &s.disps[static_cast<std::size_t>(ne.keyframes[dt.source_slot]) * HW];
    for (std::size_t k = 0; k < dt.pixel.size(); ++k) {
      double v = d[dt.pixel[k]] + st.dd[t][k];
      if (!(v >= min_d)) {
        v = min_d;
        ++clamped;
      }
      d[dt.pixel[k]] = static_cast<float>(v);
    }
  }
  return clamped;
}

/// Minimal gauge: scales the map about keyframe ka so that |c_kb − c_ka| = D0 (a similarity of the
/// world: every pixel factor is unchanged).
void holdScale(Snapshot& s, const std::vector<int>& keyframes, int ka, int kb, double D0) {
  const Eigen::Vector3d c_a = s.T_wc(ka).translation();
  const double D = (s.T_wc(kb).translation() - c_a).norm();
  const double scale = D0 / D;
  if (scale == 1.0) return;
  const std::size_t HW = s.pixelsPerFrame();
  for (int k : keyframes) {
    if (k != ka) {
      Eigen::Isometry3d T = s.T_wc(k);
      T.translation() = c_a + scale * (T.translation() - c_a);
      s.setT_wc(k, T);
    }
    float* d = &s.disps[static_cast<std::size_t>(k) * HW];
    for (std::size_t p = 0; p < HW; ++p) d[p] = static_cast<float>(d[p] / scale);
  }
}

double maxTranslation(const Snapshot& s, const std::vector<int>& keyframes) {
  double m = 0;
  for (int k : keyframes) m = std::max(m, s.T_wc(k).translation().cwiseAbs().maxCoeff());
  return m;
}

NumericalError notPositiveDefinite(const FactorizationError& e, const Linearization& L) {
  std::vector<int> kf;
  if (e.column() >= 0) {
    const auto& off = L.gauge.offset;
    const auto it = std::upper_bound(off.begin(), off.end(), e.column());
    kf.push_back(L.ne.keyframes[it - off.begin() - 1]);
  }
  return NumericalError(
      "DBA solver: the damped reduced system is not positive definite" +
          (kf.empty() ? std::string() : " (at keyframe " + joinKeyframes(kf) + ")") +
          ": a variable carries no information",
      kf);
}

}  // namespace

void DbaSolverOptions::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (max_iterations < 1) throw std::invalid_argument("DBA solver: max_iterations must be >= 1");
  if (!positive(initial_lambda) || !positive(max_lambda) || !(initial_lambda < max_lambda))
    throw std::invalid_argument("DBA solver: need 0 < initial_lambda < max_lambda");
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(step_tolerance >= 0))
    throw std::invalid_argument("DBA solver: tolerances must be >= 0");
  if (!positive(min_inverse_depth))
    throw std::invalid_argument("DBA solver: min_inverse_depth must be finite and > 0");
}

std::string toString(DbaTermination t) {
  switch (t) {
    case DbaTermination::GradientTolerance:
      return "gradient tolerance";
    case DbaTermination::FunctionTolerance:
      return "function tolerance";
    case DbaTermination::StepTolerance:
      return "step tolerance";
    case DbaTermination::MaxIterations:
      return "max iterations";
    case DbaTermination::NoDecrease:
      return "no decrease";
  }
  return "?";
}

bool DbaSolverSummary::converged() const {
  return termination == DbaTermination::GradientTolerance ||
         termination == DbaTermination::FunctionTolerance ||
         termination == DbaTermination::StepTolerance;
}

std::string DbaSolverSummary::brief() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "%d iterations (%d accepted), cost %.6g -> %.6g, gradient %.3g -> %.3g, %s",
                iterations, successful_steps, initial_cost, final_cost, initial_gradient,
                final_gradient, toString(termination).c_str());
  return buf;
}

DbaStep computeDbaStep(const Snapshot& s, const DbaOptions& o, double lambda) {
  o.validate();
  if (!(std::isfinite(lambda) && lambda >= 0))
    throw std::invalid_argument("computeDbaStep: lambda must be finite and >= 0");
  const std::vector<int> keyframes = s.graphKeyframes();
  const std::vector<Prior> priors = makePriors(s, makeGauge(o.gauge, s, keyframes), keyframes);
  const Linearization L = linearize(s, o, priors, /*min_d=*/0.0);
  Step st;
  try {
    st = dampedStep(L, lambda, Ordering::Auto);
  } catch (const FactorizationError& e) {
    throw notPositiveDefinite(e, L);
  }
  DbaStep out;
  out.keyframes = L.ne.keyframes;
  out.xi = st.xi;
  out.disp.assign(static_cast<std::size_t>(s.numKeyframes()) * s.pixelsPerFrame(), 0.0);
  for (std::size_t t = 0; t < L.ne.depths.size(); ++t) {
    const DepthTerms& dt = L.ne.depths[t];
    const std::size_t base =
        static_cast<std::size_t>(L.ne.keyframes[dt.source_slot]) * s.pixelsPerFrame();
    for (std::size_t k = 0; k < dt.pixel.size(); ++k) out.disp[base + dt.pixel[k]] = st.dd[t][k];
  }
  out.predicted_decrease = st.predicted;
  return out;
}

DbaSolverSummary solveDba(Snapshot& s, const DbaOptions& o, const DbaSolverOptions& so) {
  o.validate();
  so.validate();
  s.validate();
  const std::vector<int> keyframes = s.graphKeyframes();
  const GaugeParameterization gauge0 = makeGauge(o.gauge, s, keyframes);
  const std::vector<Prior> priors = makePriors(s, gauge0, keyframes);
  // Only the minimal gauge needs its two keyframes here (the scale it holds); the droid gauge may
  // hold a single keyframe (t0 = 1), so gauge_slots[1] need not exist.
  const bool minimal = o.gauge.type == GaugeOptions::Type::Minimal;
  const int ka = minimal ? keyframes[gauge0.gauge_slots.at(0)] : -1;
  const int kb = minimal ? keyframes[gauge0.gauge_slots.at(1)] : -1;
  const double D0 = minimal ? (s.T_wc(kb).translation() - s.T_wc(ka).translation()).norm() : 0.0;

  Linearization L = linearize(s, o, priors, so.min_inverse_depth);
  checkGaugeReachesAll(L.ne.S, L.gauge, L.ne.keyframes);
  DbaSolverSummary sum;
  sum.initial_cost = L.cost;
  sum.initial_gradient = L.gradient;
  double lambda = so.initial_lambda, nu = 2.0;
  auto done = [&](DbaTermination t) {
    sum.termination = t;
    sum.final_cost = L.cost;
    sum.final_gradient = L.gradient;
    sum.final_lambda = lambda;
    return sum;
  };
  if (L.gradient == 0) return done(DbaTermination::GradientTolerance);

  while (true) {
    if (sum.iterations >= so.max_iterations) return done(DbaTermination::MaxIterations);
    if (so.on_iteration && sum.iterations > 0) {
      sum.final_cost = L.cost;
      sum.final_gradient = L.gradient;
      sum.final_lambda = lambda;
      so.on_iteration(sum);
    }
    ++sum.iterations;
    Step st;
    try {
      st = dampedStep(L, lambda, so.ordering);
    } catch (const FactorizationError& e) {
      throw notPositiveDefinite(e, L);
    }
    if (!(st.predicted > so.function_tolerance * L.cost))
      return done(DbaTermination::FunctionTolerance);

    // Trial state; the current one is restored when the trial is rejected.
    const auto poses = s.poses_cw;
    const std::vector<float> disps = s.disps;
    const std::size_t clamped = applyStep(s, L.ne, st, so.min_inverse_depth);
    if (minimal) holdScale(s, keyframes, ka, kb, D0);
    Linearization trial = linearize(s, o, priors, so.min_inverse_depth);
    if (trial.cost < L.cost) {
      const double decrease = L.cost - trial.cost;
      const double rho = decrease / st.predicted;
      lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2.0;
      ++sum.successful_steps;
      sum.clamped_depths += clamped;
      const bool small_f = decrease <= so.function_tolerance * L.cost;
      const bool small_step =
          st.xi.size() == 0 ||
          st.xi.cwiseAbs().maxCoeff() <= so.step_tolerance * (1.0 + maxTranslation(s, keyframes));
      L = std::move(trial);
      if (L.gradient <= so.gradient_tolerance * sum.initial_gradient)
        return done(DbaTermination::GradientTolerance);
      if (small_f) return done(DbaTermination::FunctionTolerance);
      if (small_step) return done(DbaTermination::StepTolerance);
    } else {
      s.poses_cw = poses;
      s.disps = disps;
      lambda *= nu;
      nu *= 2.0;
      if (lambda > so.max_lambda) return done(DbaTermination::NoDecrease);
    }
  }
}

}  // namespace dbacov
