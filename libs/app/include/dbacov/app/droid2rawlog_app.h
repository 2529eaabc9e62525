// `droid2rawlog`: DROID-SLAM DBA snapshot dumps (.npz) → a rawlog of CObservationDbaSnapshot, and
// `--info` summaries of snapshot files and rawlogs.
#pragma once

#include <ostream>

namespace dbacov::app {

/// Returns 0 on success, 1 when any input failed (the others are still converted), 2 on bad usage.
int runDroid2RawlogApp(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace dbacov::app
