// The self-calibration of every method, including the one that needs the DBA solver: the
// parametric bootstrap (self_calibration.h, method bootstrap).
//
// The nuisance method's covariance V is exact for its fitted noise model under the
// linearization. At low SNR the solve's own nonlinearity makes DBA's estimate err more than the
// linearization says (the default scene at weight scale 4: ANEES 9.2 for white noise that the
// confidences describe exactly). The bootstrap measures that, with no ground truth: R replicates
// of the snapshot, each with targets = the state's predicted flow π(state) + noise drawn from the
// fitted model (white of variance s_e / λ, or with bootstrap_resampling = Wild each row's own
// residual r with a random sign, scaled per edge by sqrt(s_e n_e / Σ λ r²) to the same white
// energy: a few rows that err much stay those rows, so what their depths do to the solve is
// re-enacted; fields a_e ~ N(0, D) either way), are solved to the optimum from the state by
// solveDba and calibrated (nuisance)
// like the snapshot. The state's offset from each replicate's estimate, e_b = Log(T_b⁻¹ T_state)
// per keyframe (the evaluation's error with the state as the truth), against the replicate's own
// covariance V_b gives per keyframe a (m_a free coordinates)
//   k_a = Σ_b e_b,aᵀ (V_b)_aa⁻¹ e_b,a / (R m_a)   (1 ± √(2 / (R m_a)) when the solve is linear)
// and the covariance is D^½ V D^½ with D = k_a on keyframe a's coordinates. e_b is not centred:
// the replicates' mean offset is the solve's nonlinear bias, which a consistent covariance must
// cover too. The joint k over all K coordinates is reported (bootstrap_scale). Measured: closer
// at low SNR, not all the way (docs/studies/bootstrap.md: the state's depths are themselves
// estimates, and the nonlinearity around them is milder than around the truth).
//
// Assumptions: the state is (close to) the optimum of its factors (as for every residual-based
// method; --converge), the fitted model describes the noise, and the nonlinearity is the same
// around the estimate as around the truth. Cost: one nuisance calibration and R solves
// (replicates in parallel, each its own seeded stream: results do not depend on the threads).
#pragma once

#include "dbacov/core/dba_solver.h"
#include "dbacov/core/options.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

/// selfCalibrate(), and for the bootstrap method the nuisance calibration with its keyframes'
/// marginals scaled (above): bootstrap_keyframe_scales = k_a, bootstrap_scale = the joint k,
/// bootstrap_replicates = the replicates they are means over, bootstrap_failed = the others. Throws
/// what selfCalibrate throws, and NumericalError when fewer than half the replicates converge or
/// the nuisance covariance is not positive definite (its callers name the snapshot).
SelfCalibration runSelfCalibration(const Snapshot& snapshot, const DbaOptions& options,
                                   const SelfCalibrationOptions& calibration = {},
                                   const DbaSolverOptions& solver = {});

}  // namespace dbacov
