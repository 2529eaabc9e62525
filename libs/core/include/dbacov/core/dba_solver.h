// A dense bundle adjustment solver: Levenberg-Marquardt on the DBA cost of a snapshot, with the
// depths eliminated by the Schur complement and the gauge of conventions §4 held.
//
// The simulator uses it so that every synthetic snapshot's state is the optimum of its own noisy
// measurements, as DROID-SLAM's DBA makes its state. It is a solver, not a covariance method: its
// damping is a solver aid and never enters a covariance (DbaCovariance linearizes the result
// without it).
//
// Cost: F = ½ Σ rᵀ Λ r over the pixel factors that carry information under the options' filters
// (conventions §2, exactly the factors linearizeDba uses), plus, for a soft two-pose gauge, the
// priors ½ eᵀ P e with e = Log(T_wc_0⁻¹ T_wc) of the gauge keyframes, centred on their *initial*
// poses.
//
// One iteration (the linear algebra of linearization.h):
//   1. linearize at the state: S, g_S, and per depth h_k, g_k, b_k;
//   2. damp the full system Marquardt-style, H_λ = H + λ diag(H), and eliminate the depths of H_λ:
//        S_λ = S + λ diag(Hpp) + λ/(1+λ) (Hpp − S),    g_λ = g_S + λ/(1+λ) (g_p − g_S)
//      (exact: depth k enters Hpp − S as b_k b_kᵀ/h_k and now as b_k b_kᵀ/((1+λ) h_k));
//   3. reduce to the gauge coordinates (ξ_a = basis_a x_a, gauge.h) and solve S_λ,r x = −g_λ,r
//      with CHOLMOD; δξ_a = basis_a x_a, so hard-fixed components never move;
//   4. back-substitute the depths: δd_k = −(g_k + b_kᵀ δp) / ((1+λ) h_k);
//   5. trial state T_wc_a · Exp(δξ_a) (conventions §3) and d_k + δd_k; inverse depths are bounded
//   below
//      by min_inverse_depth (DROID clamps at 0.001): a step that crosses the bound is clamped, and
//      a depth at the bound whose gradient points further down is *active*: it is held (δd = 0,
//      not eliminated: its b_k b_kᵀ/((1+λ) h_k) is added back to S_λ) and left out of the
//      gradient norm, so the iteration converges to the bound-constrained optimum (a projected
//      Gauss-Newton method); under the minimal gauge the whole map is then
//      scaled about the fixed keyframe so that the distance between the two gauge keyframe
//      centres keeps its initial value exactly (a similarity of the world leaves every pixel
//      factor unchanged, so this moves nothing but the gauge);
//   6. accept the trial if the cost decreased, then λ ← λ · max(1/3, 1 − (2ρ − 1)³) with ρ the
//      ratio of actual to predicted decrease (Nielsen); otherwise λ ← λ·ν, ν ← 2ν.
// With λ = 0 the step is the Gauss-Newton step of the full (poses + depths) normal equations.
//
// Termination (checked in this order, summary.termination):
//   GradientTolerance  max |g| <= gradient_tolerance · max |g| at the start, with g the undamped
//                      gradient over the reduced pose coordinates and the free (not active)
//                      inverse depths, or the gradient is exactly zero;
//   FunctionTolerance  an accepted step decreased F by <= function_tolerance · F, or the model
//                      predicts a decrease <= function_tolerance · F (the single-precision
//                      inverse depths and targets put a floor under F; rejections there mean
//                      the optimum is reached to that precision);
//   StepTolerance      an accepted step with max |δξ| <= step_tolerance · (1 + max |t_wc|);
//   MaxIterations      max_iterations linear solves were done;
//   NoDecrease         λ exceeded max_lambda without a decrease (not converged).
//
// Errors: std::invalid_argument for invalid options; InputError for an invalid snapshot;
// NumericalError (naming keyframes) when the gauge cannot be built or reaches only part of the
// graph, or when even the damped reduced system is not positive definite (a variable without any
// information: Marquardt damping scales the diagonal, so it cannot help there).
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

struct DbaSolverSummary;

struct DbaSolverOptions {
  int max_iterations = 50;            ///< linear solves (accepted or rejected steps)
  double initial_lambda = 1e-4;       ///< Marquardt damping of the first step
  double max_lambda = 1e12;           ///< give up (NoDecrease) beyond this damping
  double function_tolerance = 1e-10;  ///< relative cost decrease that counts as converged
  double gradient_tolerance = 1e-12;  ///< relative to the initial reduced gradient (max norm)
  double step_tolerance = 1e-12;      ///< pose step (max norm) relative to 1 + the largest |t_wc|
  double min_inverse_depth = 1e-3;    ///< inverse depths never go below this (DROID's clamp)
  Ordering ordering = Ordering::Auto;
  /// Called after every iteration but the last (whose summary solveDba returns) with the summary
  /// so far (iterations, cost, gradient), e.g. to show the progress of a long solve; an exception
  /// it throws ends the solve.
  std::function<void(const DbaSolverSummary&)> on_iteration = nullptr;

  /// Throws std::invalid_argument for non-positive or non-finite values.
  void validate() const;
};

/// The iteration cap of a solve to the optimum (dba-covariance --converge, the simulator): at
/// DROID-like signal-to-noise the DBA cost is badly curved and inverse depths run into their bound,
/// where Levenberg-Marquardt zig-zags along a curved valley and may need several times its default
/// 50 iterations (a simulated sliding-window snapshot takes up to 49, a tiny 8×10 one over 200).
inline constexpr int kOptimumSolveIterations = 200;

enum class DbaTermination {
  GradientTolerance,
  FunctionTolerance,
  StepTolerance,
  MaxIterations,
  NoDecrease,
};
/// "gradient tolerance", "function tolerance", "step tolerance", "max iterations", "no decrease".
std::string toString(DbaTermination t);

struct DbaSolverSummary {
  int iterations = 0;           ///< linear solves
  int successful_steps = 0;     ///< accepted steps
  double initial_cost = 0;      ///< F at the initial state
  double final_cost = 0;        ///< F at the returned state
  double initial_gradient = 0;  ///< max |g| at the initial state (see Termination)
  double final_gradient = 0;    ///< max |g| at the returned state
  double final_lambda = 0;
  std::size_t clamped_depths = 0;  ///< inverse depths set to min_inverse_depth (all steps)
  DbaTermination termination = DbaTermination::MaxIterations;

  /// True for the three tolerance terminations.
  bool converged() const;
  /// One line: "7 iterations (7 accepted), cost 1.2e4 -> 9.8e3, gradient 3e2 -> 1e-9, function
  /// tolerance".
  std::string brief() const;
};

/// Minimizes F over the poses (gauge held) and inverse depths of the graph keyframes, starting
/// from and overwriting the snapshot's state (poses and disps). Poses of keyframes outside the
/// graph and inverse depths that are no variable (no information) are not touched.
DbaSolverSummary solveDba(Snapshot& snapshot, const DbaOptions& options,
                          const DbaSolverOptions& solver = {});

/// One damped Gauss-Newton step at the snapshot's state (steps 2–4 above), with soft gauge priors
/// centred at the current state and no bound (no active depth). Exposed for tests and diagnostics.
struct DbaStep {
  std::vector<int> keyframes;     ///< slot → keyframe (the graph keyframes)
  Eigen::VectorXd xi;             ///< δξ, 6 per slot (zero along removed gauge directions)
  std::vector<double> disp;       ///< δd per (keyframe, pixel), N·H·W, 0 where d is no variable
  double predicted_decrease = 0;  ///< F(x) − F_model(x + δ) of the undamped quadratic model
};
DbaStep computeDbaStep(const Snapshot& snapshot, const DbaOptions& options, double lambda = 0);

}  // namespace dbacov
