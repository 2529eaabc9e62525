#include "dbacov/app/snapshot_inputs.h"

#include <filesystem>

#include "dbacov/core/errors.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/rawlog_io.h"

namespace dbacov::app {
namespace fs = std::filesystem;

bool isRawlogPath(const std::string& path) { return fs::path(path).extension() == ".rawlog"; }

SnapshotInputs::SnapshotInputs(const std::vector<std::string>& paths) {
  for (const std::string& p : paths) {
    std::error_code ec;
    const fs::file_status st = fs::status(p, ec);
    if (ec || !fs::exists(st)) throw InputError(p + ": no such file or directory");
    if (fs::is_directory(st)) {
      const std::vector<std::string> found = io::listNpzFiles(p);
      if (found.empty()) throw InputError(p + ": directory holds no .npz snapshot");
      files_.insert(files_.end(), found.begin(), found.end());
    } else if (fs::path(p).extension() == ".npz" || isRawlogPath(p)) {
      files_.push_back(p);
    } else {
      throw InputError(p + ": not a snapshot input (expected a .npz file, a .rawlog of DBA "
                           "snapshots, or a directory of .npz files)");
    }
  }
}

std::size_t SnapshotInputs::knownCount() const {
  for (const auto& f : files_)
    if (isRawlogPath(f)) return 0;
  return files_.size();
}

void SnapshotInputs::forEach(const std::function<void(Snapshot&)>& process,
                             const std::function<void(const std::string&)>& on_error) const {
  std::int64_t index = 0;
  for (const std::string& file : files_) {
    if (isRawlogPath(file)) {
      // Indices continue after the last snapshot seen, even when a bad entry ends the file.
      const std::int64_t first = index;
      std::size_t seen = 0;
      try {
        mrpt_bridge::forEachRawlogSnapshot(
            file, first,
            [&](Snapshot& s) {
              ++seen;
              process(s);
            },
            [&](const InputError& e) {
              ++seen;
              on_error(e.what());
            });
      } catch (const InputError& e) {
        on_error(e.what());
      }
      index = first + static_cast<std::int64_t>(seen);
      continue;
    }
    Snapshot s;
    try {
      s = io::loadSnapshotNpz(file, index++);
    } catch (const std::exception& e) {
      on_error(e.what());
      continue;
    }
    process(s);
  }
}

}  // namespace dbacov::app
