// The `-i PATH` inputs of the apps: `.npz` snapshot files, directories of them (name order), and
// rawlogs of DBA snapshot observations (`.rawlog`).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dbacov/core/snapshot.h"

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

  /// Reads the snapshots one at a time, in order, and hands each to `process`. The n-th snapshot
  /// (0-based over all inputs, failures included) gets index n. A snapshot that cannot be read or
  /// is invalid goes to `on_error(message)` (the message names the file, entry, key or item) and
  /// the rest are still processed; an unreadable rawlog entry ends that rawlog.
  void forEach(const std::function<void(Snapshot&)>& process,
               const std::function<void(const std::string&)>& on_error) const;

 private:
  std::vector<std::string> files_;
};

bool isRawlogPath(const std::string& path);

}  // namespace dbacov::app
