// The `-i PATH` inputs of the apps: `.npz` snapshot files, directories of them (name order), and
// rawlogs of DBA snapshot observations (`.rawlog`).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dbacov/core/snapshot.h"

namespace dbacov::mrpt_bridge {
class RawlogSnapshotReader;
}

namespace dbacov::app {

class SnapshotInputs {
 public:
  /// Expands `paths` in order: a directory contributes its `.npz` files sorted by name; `.npz` and
  /// `.rawlog` files are taken as given. Throws InputError naming the path when it does not exist,
  /// when a directory holds no `.npz` file, or when a file is neither.
  explicit SnapshotInputs(const std::vector<std::string>& paths);

  /// Number of snapshots when known in advance (only `.npz` inputs), else 0.
  std::size_t knownCount() const;
  const std::vector<std::string>& files() const { return files_; }

  /// Reads the snapshots one at a time (see SnapshotStream), in order, and hands each to `process`. The n-th snapshot
  /// (0-based over all inputs, failures included) gets index n. A snapshot that cannot be read or
  /// is invalid goes to `on_error(message)` (the message names the file, entry, key or item) and
  /// the rest are still processed; an unreadable rawlog entry ends that rawlog.
  void forEach(const std::function<void(Snapshot&)>& process,
               const std::function<void(const std::string&)>& on_error) const;

 private:
  std::vector<std::string> files_;
};

/// One item of the input: a valid snapshot, or the message of one that could not be read or is
/// invalid (it names the file, entry, key or item).
struct SnapshotItem {
  Snapshot snapshot;
  std::string error;
  bool ok() const { return error.empty(); }
};

/// Pull-based reading of the inputs, one snapshot in memory at a time. The n-th item (0-based over
/// all inputs, failures included) gets index n. An unreadable rawlog entry yields an error item
/// and ends that rawlog; reading goes on with the next input.
class SnapshotStream {
 public:
  explicit SnapshotStream(const SnapshotInputs& inputs);
  ~SnapshotStream();
  /// False at the end.
  bool next(SnapshotItem* item);

 private:
  const SnapshotInputs& inputs_;
  std::size_t file_ = 0;
  std::int64_t index_ = 0;
  std::unique_ptr<mrpt_bridge::RawlogSnapshotReader> rawlog_;
};

bool isRawlogPath(const std::string& path);

}  // namespace dbacov::app
