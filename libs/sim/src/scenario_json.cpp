#include "dbacov/sim/scenario_json.h"

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "dbacov/core/errors.h"
#include "dbacov/sim/scenario_schema.h"

namespace dbacov::sim {
namespace {

using nlohmann::json;

/// Reads the object at key path `path` ("" = the file) against the schema: a key is a setting of
/// the schema, or an object that holds settings; anything else is an error (a typo).
void readObject(const json& obj, const std::string& path, const std::string& source,
                ScenarioConfig& c) {
  auto where = [&](const std::string& key) { return source + ": key '" + key + "'"; };
  if (!obj.is_object())
    throw InputError(source + ": " + (path.empty() ? "the file" : "key '" + path + "'") +
                     ": expected an object");
  for (const auto& [k, v] : obj.items()) {
    const std::string key = path.empty() ? k : path + "." + k;
    bool known = false, object = false;
    for (const ScenarioField& f : scenarioSchema()) {
      if (f.key == key) {
        f.read(v, c, where(key));
        known = true;
        break;
      }
      object |= f.key.compare(0, key.size() + 1, key + ".") == 0;
    }
    if (known) continue;
    if (!object) throw InputError(where(key) + ": unknown key");
    readObject(v, key, source, c);
  }
}

}  // namespace

void applyScenarioJson(const std::string& text, const std::string& source, ScenarioConfig& c) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(source + ": invalid JSON: " + e.what());
  }
  readObject(root, "", source, c);
}

ScenarioConfig loadScenarioConfig(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot open the scenario configuration");
  std::ostringstream text;
  text << f.rdbuf();
  if (f.bad()) throw InputError(path + ": read error");
  ScenarioConfig c;
  applyScenarioJson(text.str(), path, c);
  return c;
}

std::string scenarioConfigToJson(const ScenarioConfig& c) {
  json j = json::object();
  for (const ScenarioField& f : scenarioSchema()) {
    json* at = &j;
    std::string key = f.key;
    for (auto dot = key.find('.'); dot != std::string::npos; dot = key.find('.')) {
      at = &(*at)[key.substr(0, dot)];
      key = key.substr(dot + 1);
    }
    (*at)[key] = f.write(c);
  }
  return j.dump(2) + "\n";
}

}  // namespace dbacov::sim
