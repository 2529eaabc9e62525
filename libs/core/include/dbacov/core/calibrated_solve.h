// The DBA solved at the self-calibrated weights of its depth-only factors (--converge with
// --self-calibrate, on stereo and RGB-D snapshots).
//
// DROID's stereo edges (k, k) and RGB-D readings act on the inverse depths alone; the flow edges
// tie those depths to the poses. Per pixel that is an errors-in-variables problem: the depth is
// observed directly (reading, stereo disparity) and through the flow, whose pose part scales
// with it. Its joint least-squares estimate is consistent only when the two kinds of factors are
// weighted in their true variance ratio (Deming regression is consistent at the true ratio and
// at no other). When the depth-only factors are claimed more precise than they are, the depths
// follow their noisy readings and the translation shrinks towards zero (regression dilution); in
// the other direction their information is wasted (at α × ¼ no bias was measurable). Measured
// (6-keyframe RGB-D scene, α claimed 4× the readings' information, runs 700–709, states solved at
// the claimed α): every run's translation is 0.87–0.91 of the truth, raw ANEES 120, self-calibrated
// 62: a bias of the estimate that no covariance covers.
//
// solveDbaAtCalibratedWeights removes it the classical way (Helmert's variance components
// alternating with the adjustment): solve; estimate each depth-only component's variance factor
// relative to the flow edges' pooled one (one vce pass without the depths' term: the ratios
// only; depthOnlyRatios); divide the readings' α and each stereo edge's weights by their ratio;
// solve again, until every ratio is within `tolerance` of 1. A component with rows but no
// redundancy (so heavily over-weighted that its residuals are 0) has its weight divided by
// kUnmeasuredStep instead, until it can be measured. The flow edges keep their weights: a
// mis-weighting among them costs efficiency, not consistency, and the covariance methods model it.
// On the scene above: α within 6 % of the truth after 3 solves, raw ANEES 6.4, self-calibrated 5.3.
//
// A snapshot without depth-only factors is solved once at its own weights (plain --converge).
#pragma once

#include <optional>
#include <vector>

#include "dbacov/core/dba_solver.h"
#include "dbacov/core/options.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

/// The depth-only factors' variance factors relative to the flow's, from a self-calibration of
/// the snapshot (its white variance components: q / ρ per edge, without the field).
struct DepthOnlyRatios {
  /// Σ q / Σ redundancy over the flow edges (i ≠ j) at the snapshot's weights; 1 when they have
  /// no redundancy.
  double flow_scale = 1;
  /// The readings' variance factor / flow_scale; 1 without readings. When the readings have rows
  /// but no redundancy (each depth fits its reading exactly: α so large that the flow does not
  /// move the depths) the factor cannot be measured: `readings_unmeasured`, and this is 1.
  double sensor = 1;
  bool readings_unmeasured = false;
  /// Per edge: a stereo edge's vce scale / flow_scale, 1 for flow edges; a stereo edge with rows
  /// but no redundancy is listed in `unmeasured_edges` and has 1 here.
  std::vector<double> edge;
  std::vector<int> unmeasured_edges;
  double stereoMedian() const;  ///< over the measured stereo edges (1 without any)
};
DepthOnlyRatios depthOnlyRatios(const SelfCalibration& calibration, int num_edges);

/// Edge `edge`'s confidences (both channels, every pixel) become w / factor, computed in double.
void divideEdgeWeights(Snapshot& snapshot, int edge, double factor);

/// The step by which an unmeasurable depth-only component's weight is divided (the readings' α,
/// a stereo edge's weights) before the next solve: it is over-weighted beyond measure.
inline constexpr double kUnmeasuredStep = 100.0;

struct CalibratedSolve {
  DbaSolverSummary solver;  ///< the last solve
  DbaOptions options;       ///< the options of the last solve (α divided by sensor_depth_factor)
  int solves = 0;           ///< DBA solves done (1 when nothing was re-weighted)
  /// The readings' α was divided by this (the product over the passes; 1 without readings).
  double sensor_depth_factor = 1;
  /// Per edge: its weights were divided by this (stereo edges; 1 for the flow edges).
  std::vector<double> edge_factors;
  /// Every ratio settled within the tolerance (false: max_solves reached, or a solve failed to
  /// converge). When a re-solve fails, the snapshot, `solver`, `options` and the factors are
  /// those of the last converged solve (its failure is in `failed_solve`); when the first solve
  /// fails, its state is returned as it ended (as solveDba's).
  bool settled = true;
  std::optional<DbaSolverSummary> failed_solve;  ///< a re-solve that did not converge
  /// The largest remaining ratio's distance from 1 (max |log ratio|, as a factor: 1.02 = 2 %).
  /// With `unmeasured` a component could not be measured at the last pass and counts as
  /// kUnmeasuredStep: the real distance is at least that, and unknown.
  double last_ratio = 1;
  bool unmeasured = false;
};

/// The defaults of solveDbaAtCalibratedWeights: at most 8 solves, until every ratio is within 2 %.
inline constexpr int kCalibratedMaxSolves = 8;
inline constexpr double kCalibratedRatioTolerance = 0.02;

/// Solves `snapshot` (its state and, for stereo edges, its weights are overwritten) as above.
/// Throws what solveDba and the self-calibration throw, and std::invalid_argument for max_solves <
/// 1 or a tolerance not in (0, 1).
CalibratedSolve solveDbaAtCalibratedWeights(Snapshot& snapshot, const DbaOptions& options,
                                            int max_solves = kCalibratedMaxSolves,
                                            double tolerance = kCalibratedRatioTolerance,
                                            const DbaSolverOptions& solver = {});

}  // namespace dbacov
