// Private part of dba-covariance: the command-line options of the picture outputs (--scene,
// --snapshot, --plots, ...), kept together so that covariance_app.cpp registers them in one place.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dbacov/app/visual_outputs.h"

namespace CLI {
class App;
}

namespace dbacov::app::detail {

struct VisualCli {
  SceneOutputOptions scene;
  std::string plots_dir;
  std::string size = "1280x720";
  std::string exaggeration = "auto";

  bool any() const { return scene.enabled() || !plots_dir.empty(); }
};

/// Registers the options on `cli` (values land in `v`).
void addVisualOptions(CLI::App& cli, VisualCli& v);
/// Parses the size and exaggeration texts and validates; std::invalid_argument on bad usage.
void finishVisualOptions(VisualCli& v);
/// Appends the sinks of the requested picture outputs (they may throw InputError, see
/// visual_outputs.h).
void appendVisualSinks(std::vector<std::unique_ptr<OutputSink>>& sinks, const VisualCli& v);

/// The --help paragraph about the pictures.
extern const char* const kVisualHelp;

}  // namespace dbacov::app::detail
