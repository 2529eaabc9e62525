// `dba-covariance`: marginal pose covariances of DBA snapshots (SPEC §2–§5).
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "dbacov/core/covariance.h"
#include "dbacov/core/options.h"

namespace dbacov::app {

struct CovarianceAppOptions {
  std::vector<std::string> inputs;
  std::string csv_path, relative_csv_path, depth_sigma_dir, rawlog_path, graph_prefix;
  std::string emit = "latest", label = "DBA_COVARIANCE";
  std::string graph_edges = "covisibility";  ///< --graph-edges
  std::optional<double> fps;
  std::string solver = "sparse", ordering = "auto";
  std::string preset = "droid";
  std::optional<double> weight_scale, gauge_sigma_rot, gauge_sigma_trans, near, far,
      min_depth_ratio;
  std::optional<std::string> gauge;
  std::size_t threads = 0;  ///< 0 = all cores
  bool quiet = false;

  /// The engine options: the preset, then every option the user gave. Throws
  /// std::invalid_argument for values out of their domain or contradicting options.
  DbaOptions engineOptions() const;
  SolverOptions solverOptions() const;
};

/// Runs the app with command-line arguments (argv[0] is the program name). Returns the exit code:
/// 0 success, 1 when any input or output failed (after processing the rest), 2 on bad usage.
/// Messages go to `err`, `--help` to `out`.
int runCovarianceApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
