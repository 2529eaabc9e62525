// `simul-dba`: simulated DROID-SLAM DBA snapshots with ground truth (sim/scenario.h): the
// project's demo data and the input of consistency studies (`dba-evaluate`).
#pragma once

#include <ostream>

namespace dbacov::app {

/// Runs the app with command-line arguments (argv[0] is the program name). Returns 0 on success,
/// 1 when a snapshot could not be simulated or an output could not be written (the others are
/// still written), 2 on bad usage (including an unreadable or invalid --config file).
int runSimulApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
