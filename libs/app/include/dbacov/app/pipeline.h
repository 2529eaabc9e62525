// Independent snapshots in parallel: read in order, compute concurrently, consume in order.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "dbacov/app/snapshot_inputs.h"
#include "dbacov/core/covariance.h"

namespace dbacov::app {

struct PipelineItem {
  SnapshotItem input;                  ///< the snapshot, or why it could not be read
  std::unique_ptr<DbaCovariance> cov;  ///< set by `compute` on success
  std::string error;                   ///< set by `compute` on failure (the error alone)
  FailureKind error_kind = FailureKind::Internal;  ///< set by `compute` on failure
};

/// Reads `stream` on one thread, runs `compute` on up to `in_flight` items concurrently (the TBB
/// pool, within the process-wide ThreadLimit), and calls `consume` on one item at a time in input
/// order. At most `in_flight` snapshots are in memory, so memory does not grow with the length of
/// the input. `consume` returns false to stop the run: nothing more is read and the items in
/// flight are dropped unconsumed. An exception from any stage stops the run the same way and is
/// rethrown here once the pipeline has drained. An item the stream left pending (a deferred
/// `.npz`, SnapshotStream's defer_npz) is read by loadPending() in the concurrent stage, before
/// `compute`: independent files then inflate in parallel while the order of everything that
/// `consume` sees stays the input's.
void runSnapshotPipeline(SnapshotStream& stream, std::size_t in_flight,
                         const std::function<void(PipelineItem&)>& compute,
                         const std::function<bool(PipelineItem&)>& consume);

}  // namespace dbacov::app
