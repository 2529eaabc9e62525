// The scenario's one table (sim/scenario_schema.h) drives the JSON reader, the writer and the
// command-line overrides: every row round-trips, every flag row is on the command line, and the
// flags override the file.
#include <fstream>

#include <gtest/gtest.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "dbacov/app/scenario_options.h"
#include "dbacov/sim/scenario_json.h"
#include "dbacov/sim/scenario_schema.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

sim::ScenarioConfig parse(std::vector<std::string> args, const std::string& config = "") {
  app::ScenarioOptions o;
  CLI::App cli;
  o.add(cli);
  std::vector<const char*> argv{"test"};
  if (!config.empty()) {
    args.push_back("--config");
    args.push_back(config);
  }
  for (const auto& a : args) argv.push_back(a.c_str());
  cli.parse(static_cast<int>(argv.size()), argv.data());
  return o.resolve();
}

TEST(ScenarioSchema, EveryRowRoundTripsThroughJson) {
  sim::ScenarioConfig c;
  c.seed = 7;
  c.camera.fx = 33.5;
  c.noise.type = sim::NoiseModel::Type::Correlated;
  c.gauge.sigma_rot = 0.25;
  c.scene.boxes.push_back({Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0.4, 0.5, 0.6)});
  const std::string text = sim::scenarioConfigToJson(c);
  sim::ScenarioConfig back;
  sim::applyScenarioJson(text, "t.json", back);
  EXPECT_EQ(sim::scenarioConfigToJson(back), text);
  // Every row appears in the file, under its key path.
  const nlohmann::json j = nlohmann::json::parse(text);
  for (const sim::ScenarioField& f : sim::scenarioSchema())
    EXPECT_TRUE(j.contains(nlohmann::json::json_pointer("/" +
                                                        [&] {
                                                          std::string p = f.key;
                                                          for (char& ch : p)
                                                            if (ch == '.') ch = '/';
                                                          return p;
                                                        }())))
        << f.key;
}

TEST(ScenarioSchema, EveryFlagRowIsOnTheCommandLineAndParses) {
  app::ScenarioOptions o;
  CLI::App cli;
  o.add(cli);
  for (const sim::ScenarioField& f : sim::scenarioSchema()) {
    if (f.flag.empty()) continue;
    EXPECT_NE(cli.get_option_no_throw(f.flag), nullptr) << f.flag;
    EXPECT_TRUE(static_cast<bool>(f.parse)) << f.flag;
  }
}

TEST(ScenarioSchema, FlagsOverrideTheFileAndGaugeKeepsTheFilesSigmas) {
  testing::TempDir dir;
  std::ofstream(dir.file("s.json"))
      << R"({"window": 5, "noise": {"amplitude": 2}, "gauge": {"type": "minimal"}})";
  const sim::ScenarioConfig c =
      parse({"--window", "6", "--snapshots", "3", "--gauge", "two-pose"}, dir.file("s.json"));
  EXPECT_EQ(c.window, 6);
  EXPECT_EQ(c.trajectory.num_keyframes, 3 + 6 - 1);
  EXPECT_EQ(c.noise.amplitude, 2.0);
  EXPECT_EQ(c.gauge.type, GaugeOptions::Type::TwoPose);

  std::ofstream(dir.file("soft.json")) << R"({"gauge": {"type": "two-pose", "sigma_rot": 0.1}})";
  EXPECT_EQ(parse({"--gauge", "two-pose"}, dir.file("soft.json")).gauge.sigma_rot, 0.1);
  EXPECT_EQ(parse({"--gauge", "minimal"}, dir.file("soft.json")).gauge.sigma_rot, 0.0);
  EXPECT_THROW(parse({"--keyframes", "9", "--snapshots", "3"}), std::invalid_argument);
}

}  // namespace
}  // namespace dbacov
