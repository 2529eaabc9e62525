// `dba-posegraph`: optimizes a pose graph written by `dba-covariance --graph` (plus optional loop
// closures and absolute priors) with MRPT's optimize_graph_spa_levmarq, and writes the optimized
// poses with covariances computed from the graph's information at the solution.
#pragma once

#include <ostream>

namespace dbacov::app {

/// Returns 0 on success, 1 on input/output or numerical failure, 2 on bad usage.
int runPoseGraphApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
