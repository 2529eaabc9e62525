// Private to dbacov_app: the inputs and outputs of each app, checked by io::OutputPlan before
// anything is read or written (an output that is an input, two outputs on one file, a --graph
// prefix that names a directory). Each throws InputError; the apps report it as bad usage (exit 2).
#pragma once

#include <string>
#include <vector>

#include "dbacov/io/path_guard.h"

namespace dbacov::app {
struct CovarianceAppOptions;
}

namespace dbacov::app::detail {

struct VisualCli;

/// The four files of `--graph PREFIX` (PREFIX.graphbin, .graph, .g2o, .nodes.csv). Throws
/// InputError when PREFIX names a directory ("dir/", ".", "..") instead of a file prefix.
std::vector<std::string> graphOutputFiles(const std::string& prefix);

/// dba-covariance: -i (and the .npz files of input directories) against --csv, --relative-csv,
/// -o, --graph's files, --depth-sigma, --scene, --snapshot, --plots, --edge-csv.
void checkCovariancePaths(const CovarianceAppOptions& opt);

/// Adds `paths` as inputs/outputs of `option` to `plan` (convenience for the other apps).
void addInputs(io::OutputPlan& plan, const std::vector<std::string>& paths,
               const std::string& option, const std::string& dir_extension = "");

}  // namespace dbacov::app::detail
