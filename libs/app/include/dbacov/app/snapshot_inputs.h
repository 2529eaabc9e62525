// The `-i PATH` inputs of the apps: `.npz` snapshot files, directories of them (name order), and
// rawlogs of DBA snapshot observations (`.rawlog`).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dbacov/app/run_summary.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::mrpt_bridge {
class SnapshotRawlogReader;
}  // namespace dbacov::mrpt_bridge

namespace dbacov::app {

struct SnapshotItem;

/// The labels of the snapshots a run has taken so far, for the inputs whose labels cannot be known
/// before they are read (rawlogs): claim() throws InputError naming both sources when a label is
/// taken twice.
class SnapshotLabels {
 public:
  void claim(const Snapshot& s);

 private:
  std::map<std::int64_t, std::pair<std::string, std::string>> taken_;  ///< label → source, how
};

class SnapshotInputs {
 public:
  /// Expands `paths` in order: a directory contributes its `.npz` files sorted by name; `.npz` and
  /// `.rawlog` files are taken as given. A path that does not exist, a directory that holds no
  /// `.npz` file (or cannot be listed) and a file that is neither is a problem: it stays in the
  /// sequence as a failed input (see SnapshotStream), unless no usable input is left at all —
  /// then the constructor throws InputError with the first problem, before anything is read.
  explicit SnapshotInputs(const std::vector<std::string>& paths);

  /// Number of snapshots when known in advance (only `.npz` inputs), else 0.
  std::size_t knownCount() const;
  /// The expanded inputs in order: a file to read, or (`error` set) a path that is a problem.
  struct Entry {
    std::string path;
    std::string error;
  };
  const std::vector<Entry>& entries() const { return entries_; }

  /// Outputs name a snapshot by its label (its `id` key, else its position in the input): the
  /// tables' `snapshot` column, `--depth-sigma`'s `DIR/LABEL_KEYFRAME.npy`, the rawlog labels.
  /// Two `.npz` inputs with one label (two runs both numbered from 0) would overwrite or
  /// duplicate each other's rows and files: InputError naming both files and the label, before
  /// anything is computed. Reads only the `id` key of each `.npz` (an unreadable file is left to
  /// the run, which reports it); labels inside rawlogs are checked as they are read
  /// (SnapshotLabels).
  void checkDistinctLabels() const;

  /// Reads the snapshots one at a time (see SnapshotStream), in order, and hands each to
  /// `process`. The n-th snapshot (0-based over all inputs, failures included) gets index n. A
  /// snapshot that cannot be read or is invalid goes to `on_error(item)` (its message names the
  /// file, entry, key or item) and the rest are still processed; an unreadable rawlog entry ends
  /// that rawlog. Either callback returns false to stop (e.g. --fail-fast); an exception from
  /// either ends the loop too.
  void forEach(const std::function<bool(Snapshot&)>& process,
               const std::function<bool(const SnapshotItem&)>& on_error) const;

 private:
  std::vector<Entry> entries_;
};

/// One item of the input: a valid snapshot, or the message of one that could not be read or is
/// invalid (it names the file, entry, key or item).
struct SnapshotItem {
  Snapshot snapshot;
  std::string error;
  std::string source;  ///< on failure: the snapshot's source ("file", "file.rawlog#entry") or file
  FailureKind kind = FailureKind::InvalidInput;  ///< on failure
  /// From a stream that defers `.npz` loads: the file still to be read (and its index), instead
  /// of `snapshot` (empty meanwhile); loadPending() reads it, and only then does ok() tell
  /// whether it could be read. Empty once loaded, and for every other item.
  std::string pending_npz;
  std::int64_t pending_index = -1;
  bool ok() const { return error.empty(); }
};

/// Reads the item's pending `.npz` file, if any, exactly as an eager SnapshotStream would have
/// (the same snapshot, or the same error naming the file). Safe to call on any thread, for
/// different items concurrently; does nothing for an item that is not pending.
void loadPending(SnapshotItem* item);

/// Pull-based reading of the inputs, one snapshot in memory at a time. The n-th item (0-based over
/// all inputs, failures included) gets index n. A problem input yields an error item; an
/// unreadable rawlog entry yields an error item and ends that rawlog, and so does a rawlog that
/// holds no snapshot at all; reading goes on with the next input.
class SnapshotStream {
 public:
  /// With defer_npz, a `.npz` input is not read by next(): the item names it (pending_npz) and
  /// the caller reads it with loadPending(), e.g. on a worker thread, so that independent files
  /// inflate in parallel. Rawlogs are read by next() in either case (one stream).
  explicit SnapshotStream(const SnapshotInputs& inputs, bool defer_npz = false);
  ~SnapshotStream();
  /// False at the end.
  bool next(SnapshotItem* item);

 private:
  const SnapshotInputs& inputs_;
  bool defer_npz_ = false;
  std::size_t file_ = 0;
  std::int64_t index_ = 0;
  std::unique_ptr<mrpt_bridge::SnapshotRawlogReader> rawlog_;
  std::size_t rawlog_snapshots_ = 0;  ///< snapshots read from the current rawlog
};

/// A `.rawlog` path, or a stream that is not named `*.npz` (/dev/stdin, a pipe, a FIFO).
bool isRawlogPath(const std::string& path);

}  // namespace dbacov::app
