// The one table of the scenario settings (ScenarioConfig): each row names a setting by its JSON
// key path and, when the command line can set it, its flag, and knows how to read it from JSON,
// write it to JSON and set it from the text of a flag. The JSON reader and writer (scenario_json.h)
// and the command-line overrides of simul-dba and dba-evaluate (app/scenario_options.h) all walk
// this table, so a setting is declared once.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "dbacov/sim/scenario.h"

namespace dbacov::sim {

struct ScenarioField {
  std::string key;   ///< JSON key path, "noise.correlation_length_px" (objects nest by '.')
  std::string flag;  ///< command-line flag ("--correlation-length"), empty: JSON only
  std::string help;  ///< flag description
  /// Reads the value into the config. `where` names the file and key for errors; throws InputError
  /// ("<where>: expected a number") for a value of the wrong JSON type or an unknown name.
  std::function<void(const nlohmann::json& value, ScenarioConfig& config, const std::string& where)>
      read;
  /// The value of the config as JSON.
  std::function<nlohmann::json(const ScenarioConfig& config)> write;
  /// Sets the value from a flag's text; throws std::invalid_argument naming the flag.
  std::function<void(const std::string& text, ScenarioConfig& config)> parse;
  /// Allowed texts of an enum flag (for the CLI's check), empty for other types.
  std::vector<std::string> choices;
  std::string type_name;  ///< for help texts: INT, FLOAT, TEXT, ...
};

/// Every setting, in the order the writer emits them and the command line applies them.
const std::vector<ScenarioField>& scenarioSchema();

/// The row of a flag, or nullptr.
const ScenarioField* findScenarioFlag(const std::string& flag);

}  // namespace dbacov::sim
