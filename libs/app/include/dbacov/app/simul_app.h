// `simul-dba`: synthetic DBA snapshots with ground truth (the project's own demo data).
#pragma once

#include <ostream>

namespace dbacov::app {

/// Runs the app; returns 0 on success, 1 on I/O failure, 2 on bad usage.
int runSimulApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
