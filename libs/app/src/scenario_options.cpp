#include "dbacov/app/scenario_options.h"

#include <stdexcept>

#include <CLI/CLI.hpp>

#include "dbacov/core/keyframe_times.h"
#include "dbacov/sim/scenario_json.h"

namespace dbacov::app {

void ScenarioOptions::add(CLI::App& cli) {
  const std::string g = "Scenario (override --config)";
  cli.add_option("--config", config_path, "Scenario configuration (JSON, e.g. share/sim/*.json)")
      ->group(g);
  cli.add_option("--mode", mode,
                 "sliding-window (one snapshot per new keyframe, DROID's frontend) or whole (one "
                 "snapshot of the whole trajectory)")
      ->check(CLI::IsMember({"sliding-window", "whole"}))
      ->group(g);
  cli.add_option("--trajectory", trajectory, "line, loop or explore-return")
      ->check(CLI::IsMember({"line", "loop", "explore-return"}))
      ->group(g);
  cli.add_option("--keyframes", keyframes, "Keyframes of the whole sequence")
      ->check(CLI::Range(2, 1000000))
      ->group(g);
  cli.add_option("--snapshots", snapshots,
                 "Sliding window: number of snapshots (keyframes = snapshots + window - 1)")
      ->check(CLI::Range(1, 1000000))
      ->group(g);
  cli.add_option("--window", window, "Sliding window: keyframes per snapshot graph (W)")
      ->check(CLI::Range(2, 100000))
      ->group(g);
  cli.add_option("--height", height, "Grid height, pixels (default 48)")
      ->check(CLI::Range(2, 4096))
      ->group(g);
  cli.add_option(
         "--width", width,
         "Grid width, pixels (default 64); fx = fy = 0.87 width unless the config sets them")
      ->check(CLI::Range(2, 4096))
      ->group(g);
  cli.add_option("--edge-radius", edge_radius,
                 "Link keyframes at most this far apart (temporal edges)")
      ->check(CLI::Range(1, 100000))
      ->group(g);
  cli.add_option("--overlap-threshold", overlap_threshold,
                 "Also link farther keyframes whose views overlap this much (0 = off)")
      ->check(CLI::Range(0.0, 1.0))
      ->group(g);
  cli.add_option("--weights", weights,
                 "Confidence distribution: uniform, beta (shape from the config) or constant")
      ->check(CLI::IsMember({"uniform", "beta", "constant"}))
      ->group(g);
  cli.add_option("--weight-min", weight_min, "Smallest confidence (uniform, beta)")->group(g);
  cli.add_option("--weight-max", weight_max, "Largest confidence (uniform, beta)")->group(g);
  cli.add_option("--zero-fraction", zero_fraction, "Fraction of pixels with zero confidence")
      ->group(g);
  cli.add_option("--noise", noise,
                 "Target noise: white (independent pixels, consistent) or correlated (Gaussian "
                 "random field per edge and axis)")
      ->check(CLI::IsMember({"white", "correlated"}))
      ->group(g);
  cli.add_option("--correlation-length", correlation_length,
                 "Correlated noise: correlation length, pixels")
      ->group(g);
  cli.add_option("--noise-amplitude", noise_amplitude,
                 "Multiplies the target noise (1 = the variance 1/(weight_scale w) that the "
                 "confidences claim)")
      ->group(g);
  cli.add_option("--weight-scale", weight_scale,
                 "Information per unit confidence, px^-2 (default 4)")
      ->check(CLI::PositiveNumber)
      ->group(g);
  cli.add_option("--gauge", gauge,
                 "Gauge of the solve, held at the truth: two-pose (hard) or minimal")
      ->check(CLI::IsMember({"two-pose", "minimal"}))
      ->group(g);
  cli.add_option("--seed", seed, "Random seed of the scenario")->group(g);
  cli.add_option("--fps", fps, "Camera rate: keyframe time = start + tstamp / fps (tstamp = 3 k)")
      ->check(CLI::PositiveNumber)
      ->group(g);
  cli.add_option("--start-time", start_time,
                 "Time of image 0, seconds since 1970 (MRPT treats 0 as 'no time')")
      ->group(g);
  cli.add_flag("--no-solve", no_solve,
               "Store the ground truth as the state instead of solving the DBA")
      ->group(g);
}

bool ScenarioOptions::anyScenarioSetting() const {
  return !config_path.empty() || mode || trajectory || weights || noise || gauge || keyframes ||
         snapshots || window || height || width || edge_radius || overlap_threshold || weight_min ||
         weight_max || zero_fraction || correlation_length || noise_amplitude || seed || no_solve;
}

sim::ScenarioConfig ScenarioOptions::resolve() const {
  sim::ScenarioConfig c =
      config_path.empty() ? sim::ScenarioConfig{} : sim::loadScenarioConfig(config_path);
  if (mode) c.mode = sim::parseSimulationMode(*mode);
  if (trajectory) c.trajectory.type = sim::parseTrajectoryType(*trajectory);
  if (window) c.window = *window;
  if (keyframes && snapshots)
    throw std::invalid_argument("give either --keyframes or --snapshots, not both");
  if (keyframes) c.trajectory.num_keyframes = *keyframes;
  if (snapshots) {
    if (c.mode != sim::SimulationMode::SlidingWindow)
      throw std::invalid_argument("--snapshots applies to --mode sliding-window only");
    c.trajectory.num_keyframes = *snapshots + c.window - 1;
  }
  if (height) c.camera.H = *height;
  if (width) c.camera.W = *width;
  if (edge_radius) c.edges.edge_radius = *edge_radius;
  if (overlap_threshold) c.edges.overlap_threshold = *overlap_threshold;
  if (weights) c.weights.distribution = sim::parseWeightDistribution(*weights);
  if (weight_min) c.weights.min = *weight_min;
  if (weight_max) c.weights.max = *weight_max;
  if (zero_fraction) c.weights.zero_fraction = *zero_fraction;
  if (noise) c.noise.type = sim::parseNoiseType(*noise);
  if (correlation_length) c.noise.correlation_length_px = *correlation_length;
  if (noise_amplitude) c.noise.amplitude = *noise_amplitude;
  if (weight_scale) c.weight_scale = *weight_scale;
  if (gauge) {
    c.gauge.type = *gauge == "minimal" ? GaugeOptions::Type::Minimal : GaugeOptions::Type::TwoPose;
    c.gauge.sigma_rot = c.gauge.sigma_trans = 0;
  }
  if (seed) c.seed = *seed;
  if (fps) {
    checkFps(*fps);
    c.time.fps = *fps;
  }
  if (start_time) c.time.start_time = *start_time;
  if (no_solve) c.solve = false;
  c.validate();
  return c;
}

}  // namespace dbacov::app
