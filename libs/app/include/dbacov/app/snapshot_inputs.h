// The `-i PATH` inputs of the apps: `.npz` files, or directories of them processed in name order.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dbacov/core/snapshot.h"

namespace dbacov::app {

class SnapshotInputs {
 public:
  /// Expands `paths` in order: a directory contributes its `.npz` files sorted by name, a file is
  /// taken as given. Throws InputError naming the path when it does not exist, when a directory
  /// holds no `.npz` file, or when a file is not an `.npz`.
  explicit SnapshotInputs(const std::vector<std::string>& paths);

  /// Number of snapshots (files).
  std::size_t size() const { return files_.size(); }
  const std::vector<std::string>& files() const { return files_; }

  /// Loads the snapshots one at a time, in order, and hands each to `process`. The n-th snapshot
  /// (0-based, failures included) gets index n. A snapshot that fails to load is reported through
  /// `on_error(source, message)` and skipped; the rest are still processed.
  void forEach(const std::function<void(Snapshot&)>& process,
               const std::function<void(const std::string&, const std::string&)>& on_error) const;

 private:
  std::vector<std::string> files_;
};

}  // namespace dbacov::app
