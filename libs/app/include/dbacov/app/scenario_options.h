// Command-line options that select and override a simulated scenario (sim/scenario.h), shared by
// `simul-dba` and the Monte Carlo mode of `dba-evaluate`. The settings are the rows of
// sim/scenario_schema.h (the same table that reads and writes the JSON files): most have a flag
// of their own, and every one (those that do not, e.g. noise.outlier_fraction, too) can be given
// as `--set KEY=VALUE` with its JSON key.
//
// Precedence: the defaults of ScenarioConfig, then the `--config FILE` (share/sim/*.json, see
// sim/scenario_json.h), then the flags, then every `--set` in the order given.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dbacov/sim/scenario.h"

namespace CLI {
class App;
}

namespace dbacov::app {

struct ScenarioOptions {
  std::string config_path;
  std::map<std::string, std::string> given;  ///< flag → text, for the rows of the schema
  /// --set KEY=VALUE, in the order given (VALUE: JSON, or else a string).
  std::vector<std::string> sets;
  std::optional<int> snapshots;  ///< sliding window: keyframes = snapshots + W − 1
  bool no_solve = false;

  /// True when any scenario setting other than --weight-scale, --fps and --start-time was given.
  bool anyScenarioSetting() const;
  /// Registers the options on `cli` (group "Scenario").
  void add(CLI::App& cli);
  /// The configuration: defaults, then the file, then the options. Throws InputError when the
  /// file cannot be read or parsed, std::invalid_argument for contradicting or invalid values.
  sim::ScenarioConfig resolve() const;

  /// The number given with `flag` (e.g. "--fps"), or nothing. std::invalid_argument if no number.
  std::optional<double> number(const std::string& flag) const;
};

}  // namespace dbacov::app
