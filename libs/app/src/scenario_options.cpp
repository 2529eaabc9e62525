#include "dbacov/app/scenario_options.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "dbacov/core/keyframe_times.h"
#include "dbacov/sim/scenario_json.h"
#include "dbacov/sim/scenario_schema.h"
#include "engine_cli.h"

namespace dbacov::app {
namespace {

/// The checks the command line applies to a row's text before the row parses it (ranges keep
/// sizes within what a grid and a trajectory allow).
void addChecks(CLI::Option* o, const std::string& flag) {
  static const std::map<std::string, std::pair<long long, long long>> integers = {
      {"--keyframes", {2, 1000000}}, {"--window", {2, 100000}},      {"--height", {2, 4096}},
      {"--width", {2, 4096}},        {"--edge-radius", {1, 100000}},
  };
  if (const auto r = integers.find(flag); r != integers.end())
    o->check(detail::integerIn(r->second.first, r->second.second));
  if (flag == "--overlap-threshold") o->check(detail::numberIn(0.0, 1.0));
  if (flag == "--weight-scale" || flag == "--fps") o->check(detail::positiveNumber());
}

}  // namespace

void ScenarioOptions::add(CLI::App& cli) {
  const std::string g = "Scenario (override --config)";
  cli.add_option("--config", config_path, "Scenario configuration (JSON, e.g. share/sim/*.json)")
      ->group(g);
  for (const sim::ScenarioField& f : sim::scenarioSchema()) {
    if (f.flag.empty()) continue;
    const std::string flag = f.flag;
    CLI::Option* o = cli.add_option_function<std::string>(
        flag, [this, flag](const std::string& text) { given[flag] = text; }, f.help);
    o->group(g);
    o->type_name(f.type_name);
    if (!f.choices.empty()) o->check(CLI::IsMember(f.choices));
    addChecks(o, flag);
    if (flag == "--keyframes")
      cli.add_option("--snapshots", snapshots,
                     "Sliding window: number of snapshots (keyframes = snapshots + window - 1)")
          ->check(detail::integerIn(1, 1000000))
          ->group(g);
  }
  cli.add_flag("--no-solve", no_solve,
               "Store the ground truth as the state instead of solving the DBA")
      ->group(g);
  cli.add_option("--set", sets,
                 "Any scenario setting by its JSON key, e.g. --set noise.correlation_length_px=3 "
                 "(repeatable, after the flags; VALUE is JSON, else text; every key: the "
                 "scenario.json a run writes)")
      ->type_name("KEY=VALUE")
      ->group(g);
}

namespace {

/// One --set: the schema row of KEY reads VALUE as JSON (a number, true/false, [x, y, z]) or,
/// when it is none, as the text itself (an enum's name).
void applySet(const std::string& arg, sim::ScenarioConfig& c) {
  const std::size_t eq = arg.find('=');
  if (eq == std::string::npos || eq == 0)
    throw std::invalid_argument("--set '" + arg + "': expected KEY=VALUE");
  const std::string key = arg.substr(0, eq), text = arg.substr(eq + 1);
  const sim::ScenarioField* row = nullptr;
  for (const sim::ScenarioField& f : sim::scenarioSchema())
    if (f.key == key) row = &f;
  if (!row) {
    std::string keys;
    for (const sim::ScenarioField& f : sim::scenarioSchema())
      keys += (keys.empty() ? "" : ", ") + f.key;
    throw std::invalid_argument("--set: unknown scenario key '" + key + "'; the keys: " + keys);
  }
  nlohmann::json value = nlohmann::json::parse(text, nullptr, false);
  if (value.is_discarded()) value = text;
  try {
    row->read(value, c, "--set " + key);
  } catch (const std::exception& e) {
    throw std::invalid_argument(e.what());
  }
}

}  // namespace

bool ScenarioOptions::anyScenarioSetting() const {
  for (const auto& [flag, text] : given)
    if (flag != "--weight-scale" && flag != "--fps" && flag != "--start-time") return true;
  return !config_path.empty() || snapshots || no_solve || !sets.empty();
}

std::optional<double> ScenarioOptions::number(const std::string& flag) const {
  const auto it = given.find(flag);
  if (it == given.end()) return std::nullopt;
  const std::string& text = it->second;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0])) || *end != '\0' ||
      !std::isfinite(v))
    throw std::invalid_argument(flag + " '" + text + "': expected a finite number");
  return v;
}

sim::ScenarioConfig ScenarioOptions::resolve() const {
  sim::ScenarioConfig c =
      config_path.empty() ? sim::ScenarioConfig{} : sim::loadScenarioConfig(config_path);
  if (given.count("--keyframes") && snapshots)
    throw std::invalid_argument("give either --keyframes or --snapshots, not both");
  for (const sim::ScenarioField& f : sim::scenarioSchema())
    if (const auto it = given.find(f.flag); !f.flag.empty() && it != given.end())
      f.parse(it->second, c);
  if (snapshots) {
    if (c.mode != sim::SimulationMode::SlidingWindow)
      throw std::invalid_argument("--snapshots applies to --mode sliding-window only");
    c.trajectory.num_keyframes = *snapshots + c.window - 1;
  }
  for (const std::string& arg : sets) applySet(arg, c);
  if (no_solve) c.solve = false;
  if (given.count("--fps")) checkFps(c.time.fps);
  c.validate();
  return c;
}

}  // namespace dbacov::app
