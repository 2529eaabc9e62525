// The parametric bootstrap of the nuisance self-calibration (self_calibration.h), a study
// variant that needs the DBA solver.
//
// The nuisance method's covariance V is exact for its fitted noise model under the
// linearization. At low SNR the solve's own nonlinearity makes DBA's estimate err more than the
// linearization says (the default scene at weight scale 4: ANEES 9.2 for white noise that the
// confidences describe exactly). The bootstrap measures that, with no ground truth: R replicates
// of the snapshot, each with targets = the state's predicted flow π(state) + noise drawn from the
// fitted model (white of variance s_e / λ, or with BootstrapOptions::resampling = Wild each row's
// own residual r with a random sign, scaled per edge by sqrt(s_e n_e / Σ λ r²) to the same white
// energy: a few rows that err much stay those rows, so what their depths do to the solve is
// re-enacted; fields a_e ~ N(0, D) either way), are solved to the optimum from the state by
// solveDba and calibrated (nuisance)
// like the snapshot. The state's offset from each replicate's estimate, e_b = Log(T_b⁻¹ T_state)
// per keyframe (the evaluation's error with the state as the truth), against the replicate's own
// covariance V_b gives per keyframe a (m_a free coordinates)
//   k_a = Σ_b e_b,aᵀ (V_b)_aa⁻¹ e_b,a / (R m_a)   (1 ± √(2 / (R m_a)) when the solve is linear)
// and the covariance is D^½ V D^½ with D = k_a on keyframe a's coordinates. e_b is not centred:
// the replicates' mean offset is the solve's nonlinear bias, which a consistent covariance must
// cover too. The joint k over all K coordinates is reported (BootstrapCalibration::scale). Closer
// at low SNR, not all the way (docs/studies/bootstrap.md: the state's depths are themselves
// estimates, and the nonlinearity around them is milder than around the truth).
//
// Assumptions: the state is (close to) the optimum of its factors (as for every residual-based
// method; --converge), the fitted model describes the noise, and the nonlinearity is the same
// around the estimate as around the truth. Cost: one nuisance calibration and R solves
// (replicates in parallel, each its own seeded stream: results do not depend on the threads).
#pragma once

#include <vector>

#include "dbacov/core/dba_solver.h"
#include "dbacov/core/enum_names.h"
#include "dbacov/core/options.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

/// How the bootstrap draws each replicate's white noise. Parametric: Gaussian of variance s_e / λ
/// at every row. Wild: the row's own standardized residual with a random sign, rescaled per edge
/// to the same energy s_e (the residuals' heavy tails, and where they are, carried over).
enum class BootstrapResampling { Parametric, Wild };
template <>
struct EnumNames<BootstrapResampling> {
  static constexpr const char* what = "bootstrap resampling";
  static constexpr std::array<std::pair<BootstrapResampling, const char*>, 2> entries{
      {{BootstrapResampling::Parametric, "parametric"}, {BootstrapResampling::Wild, "wild"}}};
};

struct BootstrapOptions {
  /// Re-solved replicates (>= 4) and the seed of their noise (the same seed gives the same
  /// covariance, whatever the number of threads).
  int replicates = 32;
  unsigned long long seed = 1;
  BootstrapResampling resampling = BootstrapResampling::Parametric;
  /// Throws std::invalid_argument for fewer than 4 replicates.
  void validate() const;
};

struct BootstrapCalibration {
  /// The nuisance calibration with its covariance rescaled (method "bootstrap"; no depths' term:
  /// the bootstrap re-solves, its scale measures the nonlinearity itself).
  SelfCalibration calibration;
  double scale = 1;                     ///< the joint k over all free coordinates
  std::vector<double> keyframe_scales;  ///< per graph keyframe (ascending) k_a; 1 when fixed
  int replicates = 0;                   ///< the replicates the scales are means over
  int failed = 0;                       ///< replicates whose solve did not converge
};

/// The nuisance calibration with its keyframes' marginals scaled (above). Throws what
/// selfCalibrate throws, and NumericalError when fewer than half the replicates converge or the
/// nuisance covariance is not positive definite (its callers name the snapshot).
BootstrapCalibration bootstrapSelfCalibration(const Snapshot& snapshot, const DbaOptions& options,
                                              const SelfCalibrationOptions& calibration = {},
                                              const BootstrapOptions& bootstrap = {},
                                              const DbaSolverOptions& solver = {});

}  // namespace dbacov
