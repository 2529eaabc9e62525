// A simulated DROID-SLAM run with ground truth: a scene, a trajectory, DROID-like edges, per-pixel
// confidences and target noise, and the DBA snapshots that DROID's frontend would produce, each
// solved to the optimum of its own noisy measurements (dba_solver.h).
//
// Modes:
//   SlidingWindow    one snapshot per new keyframe once W exist (DROID's frontend): snapshot s
//                    holds keyframes 0..s+W−1 in `poses` and edges among the last W (s..s+W−1);
//                    keyframes before s keep their true poses and take part in no edge.
//   WholeTrajectory  one snapshot with every keyframe and edges among all of them.
// Edges: temporal neighbours (|i − j| <= radius) plus pairs whose true views overlap
// (covisibility.h), both directions. A pixel of frame i carries no information on an edge (i, j)
// (weight 0 on both axes) when its point is behind camera j, projects outside image j, or is
// hidden there by a nearer surface (the network cannot match it); the rest get confidences from
// the weight model and targets = true projection + noise of variance 1/(weight_scale·w)
// (pixel_models.h).
//
// State of a snapshot: the truth perturbed (poses by Exp(ξ), ξ ~ N(0, diag(σ_t², σ_r²)); inverse
// depths by a factor exp(σ_d n)), then solved with the DBA solver under `gauge` and DROID's pixel
// filter (DbaOptions::droid() with the scenario's weight scale: engineOptions()). The gauge is
// held *at the truth*: the two-pose gauge keyframes start (and, when hard, stay) at their true
// poses; under the minimal gauge the first keyframe is true and the second starts at its true
// distance from it. (A soft two-pose prior is centred at the truth and lets them move.)
// The estimate is then expressed in the true frame and scale, which is what makes absolute NEES
// meaningful (conventions §7); DROID itself holds its oldest poses at their estimates instead.
// Under the `droid` gauge (stereo, RGB-D) only the first keyframe is held (at the truth); the
// second starts perturbed like the others, scale included.
// Sensor modes (SensorConfig): stereo adds the edge (k, k) per source keyframe k, with targets
// through the rig (visibility and occlusion checked in the
// right camera as for any edge); RGB-D sets disps_sens on the source keyframes.
//
// Randomness: every stream is seeded from (seed, purpose, snapshot[, run]) so that a snapshot
// depends only on the configuration, its index and the run: confidences are fixed by the
// scenario, while target noise and the initial perturbation are redrawn for every Monte Carlo run
// (`run`) and every snapshot (DROID re-predicts its targets at every update).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/sim/covisibility.h"
#include "dbacov/sim/image_flow.h"
#include "dbacov/sim/pixel_models.h"
#include "dbacov/sim/scene.h"
#include "dbacov/sim/trajectory.h"

namespace dbacov::sim {

struct CameraConfig {
  int H = 48, W = 64;
  /// Unset: fx = fy = 0.87·W (≈ 60° horizontal field of view), cx = (W−1)/2, cy = (H−1)/2.
  std::optional<double> fx, fy, cx, cy;
  PinholeIntrinsics intrinsics() const;
};

enum class SimulationMode { SlidingWindow, WholeTrajectory };
/// "sliding-window", "whole"; throws std::invalid_argument otherwise.
SimulationMode parseSimulationMode(const std::string& name);
std::string toString(SimulationMode m);

/// Where a sliding-window snapshot's gauge keyframes are held. Truth: at their true poses (the
/// default: each snapshot's estimate lives in the true frame and scale, so its absolute NEES is
/// meaningful). Estimate: at the previous snapshot's estimates of them, as DROID's frontend
/// holds them: the frame and the monocular scale then drift from window to window as in DROID,
/// and a snapshot's error is relative to the gauge it inherited (only a whole-sequence result,
/// held at the first snapshot's truth, compares with the ground truth). Simulated in order,
/// each snapshot from the one before (Scenario::simulate's `previous`).
enum class GaugeHold { Truth, Estimate };
/// "truth", "estimate"; throws std::invalid_argument otherwise.
GaugeHold parseGaugeHold(const std::string& name);
std::string toString(GaugeHold h);

struct InitialPerturbation {
  double translation = 0.02;    ///< σ_t, metres (per axis of ρ)
  double rotation = 0.01;       ///< σ_r, radians (per axis of φ)
  double inverse_depth = 0.05;  ///< σ_d of the log inverse depth
};

struct TimeConfig {
  double frame_interval = 3.0;  ///< `tstamp` of keyframe k is k·frame_interval (image index)
  double fps = 20.0;            ///< keyframe time = start_time + tstamp / fps (seconds)
  double start_time = 1.7e9;    ///< seconds since 1970 (MRPT treats 0 as "no time")
};

/// The default sequence: 12 keyframes (5 snapshots of a window of 8).
inline TrajectoryConfig defaultScenarioTrajectory() {
  TrajectoryConfig t;
  t.num_keyframes = 12;
  return t;
}

/// The default edges: temporal neighbours within 2 keyframes plus, per keyframe, the two
/// best-overlapping farther keyframes whose views overlap >= 50 % (DROID's proximity edges).
inline CovisibilityConfig defaultScenarioEdges() {
  CovisibilityConfig e;
  e.edge_radius = 2;
  e.overlap_threshold = 0.5;
  e.max_overlap_edges = 2;
  e.candidate_distance = 1.0;
  return e;
}

/// The solver of the simulation: up to kOptimumSolveIterations (DROID-like signal-to-noise makes
/// the DBA cost badly curved; Levenberg-Marquardt then needs more than its default 50 to converge).
inline DbaSolverOptions defaultScenarioSolver() {
  DbaSolverOptions o;
  o.max_iterations = kOptimumSolveIterations;
  return o;
}

/// The DROID-SLAM mode simulated (conventions §2): monocular flow only, or with the stereo factor
/// (an edge ii == jj per source keyframe to the right camera of a rig, DROID's stereo mode) or the
/// depth-sensor factor (RGB-D). Both carry metric information: the scale is then observable and
/// the `droid` gauge may hold a single keyframe.
enum class SensorMode { Mono, Stereo, Rgbd };
}  // namespace dbacov::sim

template <>
struct dbacov::EnumNames<dbacov::sim::SensorMode> {
  static constexpr const char* what = "sensor";
  static constexpr std::array<std::pair<sim::SensorMode, const char*>, 3> entries{
      {{sim::SensorMode::Mono, "mono"},
       {sim::SensorMode::Stereo, "stereo"},
       {sim::SensorMode::Rgbd, "rgbd"}}};
};

namespace dbacov::sim {
/// The names of the table above; throws std::invalid_argument for an unknown name.
SensorMode parseSensorMode(const std::string& name);
std::string toString(SensorMode m);

struct SensorConfig {
  SensorMode mode = SensorMode::Mono;
  /// Stereo: the right camera sits `stereo_baseline` metres along +x of the left one, so that a
  /// point X of the left camera is Y = X − (b, 0, 0) in the right one (stereo_rig = [−b 0 0 0 0 0
  /// 1], DROID's rig with b = 0.1). Its targets get the confidences and noise of every edge.
  double stereo_baseline = 0.1;
  /// RGB-D: information α of one reading, (inverse depth)⁻²: d_sens = d_true + N(0, 1/α). It is
  /// also the engine's sensor_depth_weight (engineOptions), so that the model is the truth.
  double depth_alpha = 400.0;
  double depth_valid_fraction = 0.8;  ///< RGB-D: fraction of the pixels with a reading
};

struct ScenarioConfig {
  CameraConfig camera;
  SensorConfig sensor;
  RoomScene scene;
  TrajectoryConfig trajectory = defaultScenarioTrajectory();  ///< num_keyframes: whole sequence
  CovisibilityConfig edges = defaultScenarioEdges();
  WeightModel weights;
  NoiseModel noise;
  /// Fixed: every run's errors follow `noise`. Open: every run draws its own error model from the
  /// open family around `noise` (drawNoiseModel, pixel_models.h).
  NoiseFamily noise_family = NoiseFamily::Fixed;
  /// Where the targets come from: the noise model (default) or rendered images through a registered
  /// optical flow estimator (image_flow.h); with an estimator, `weights` and `noise` are unused.
  ImageFlowConfig flow;
  double weight_scale = 4.0;  ///< information of a target = weight_scale · w (px⁻²)
  SimulationMode mode = SimulationMode::SlidingWindow;
  int window = 8;  ///< W, SlidingWindow only
  /// Default: two-pose, hard (the paper's). `droid` holds the first keyframe of each snapshot's
  /// graph only (t0 = that keyframe + 1, DROID's rule): stereo or RGB-D only, since monocular DBA
  /// leaves the scale free.
  GaugeOptions gauge;
  GaugeHold gauge_hold = GaugeHold::Truth;
  InitialPerturbation perturbation;
  bool solve = true;  ///< false: the stored state is the truth (no solve)
  DbaSolverOptions solver = defaultScenarioSolver();
  TimeConfig time;
  std::uint64_t seed = 1;

  /// Throws std::invalid_argument naming the offending setting (also for a --flow estimator that
  /// this program has not registered, image_flow.h).
  void validate() const;
  int numSnapshots() const;
  /// The engine options of the solve (and of a consistent covariance computation): DROID's
  /// preset with this weight scale and gauge.
  DbaOptions engineOptions() const;
};

struct SimulatedSnapshot {
  Snapshot snapshot;                         ///< valid; state = solved optimum (or truth)
  std::vector<Eigen::Isometry3d> T_wc_true;  ///< per keyframe of `poses`
  DbaSolverSummary solver;                   ///< iterations = 0 when not solved
  NoiseModel noise;  ///< the run's error model (drawn, with the open family)
};

class Scenario {
 public:
  /// Validates the configuration, builds the true trajectory, depth maps and edges. Throws
  /// std::invalid_argument when the configuration is invalid or a camera is not in free space.
  explicit Scenario(ScenarioConfig config);

  const ScenarioConfig& config() const { return config_; }
  int numSnapshots() const { return static_cast<int>(edges_.size()); }
  int numKeyframes() const { return static_cast<int>(T_wc_true_.size()); }
  /// True camera-to-world pose of every keyframe of the sequence.
  const std::vector<Eigen::Isometry3d>& groundTruth() const { return T_wc_true_; }
  /// Seconds of keyframe k (TimeConfig).
  double keyframeTime(int k) const;
  /// Directed edges (i, j) of snapshot s, sorted.
  const std::vector<std::pair<int, int>>& edges(int s) const { return edges_.at(s); }

  /// Snapshot s (0-based) of noise draw `run`; `id` = s. Deterministic. Throws NumericalError
  /// when the solve fails (an unobservable variable). With GaugeHold::Estimate and s > 0,
  /// `previous` is the last earlier snapshot that was simulated (simul-dba: s − 1, or the one
  /// before it when s − 1 failed): its estimates hold the gauge keyframes (two-pose: both, bit
  /// for bit; minimal: the first, the second starts there and keeps its distance; droid: the
  /// first), the other keyframes it has start from its estimates perturbed, a new keyframe from
  /// its predecessor's estimate moved by the true motion, perturbed; the inverse depths start from
  /// the perturbed truth as always. std::invalid_argument when it is missing or lacks a gauge
  /// keyframe.
  SimulatedSnapshot simulate(int s, std::uint64_t run = 0,
                             const Snapshot* previous = nullptr) const;

 private:
  ScenarioConfig config_;
  PinholeIntrinsics K_;
  std::vector<Eigen::Isometry3d> T_wc_true_;
  std::vector<std::vector<double>> disp_true_;  ///< per keyframe, H·W
  std::vector<std::vector<std::pair<int, int>>> edges_;
};

/// A well-mixed 64-bit seed for (seed, purpose, a, b) (SplitMix64 finalizer over the inputs).
std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t purpose, std::uint64_t a,
                      std::uint64_t b = 0);

}  // namespace dbacov::sim
