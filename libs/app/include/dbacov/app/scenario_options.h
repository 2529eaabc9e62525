// Command-line options that select and override a simulated scenario (sim/scenario.h), shared by
// `simul-dba` and the Monte Carlo mode of `dba-evaluate`.
//
// Precedence: the defaults of ScenarioConfig, then the `--config FILE` (share/sim/*.json, see
// sim/scenario_json.h), then every option given on the command line.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "dbacov/sim/scenario.h"

namespace CLI {
class App;
}

namespace dbacov::app {

struct ScenarioOptions {
  std::string config_path;
  std::optional<std::string> mode, trajectory, weights, noise, gauge;
  std::optional<int> keyframes, snapshots, window, height, width, edge_radius;
  std::optional<double> overlap_threshold, weight_min, weight_max, zero_fraction,
      correlation_length, noise_amplitude, weight_scale, fps, start_time;
  std::optional<std::uint64_t> seed;
  bool no_solve = false;

  /// True when any scenario setting other than --weight-scale, --fps and --start-time was given.
  bool anyScenarioSetting() const;
  /// Registers the options on `cli` (group "Scenario").
  void add(CLI::App& cli);
  /// The configuration: defaults, then the file, then the options. Throws InputError when the
  /// file cannot be read or parsed, std::invalid_argument for contradicting or invalid values.
  sim::ScenarioConfig resolve() const;
};

}  // namespace dbacov::app
