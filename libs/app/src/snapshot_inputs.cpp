#include "dbacov/app/snapshot_inputs.h"

#include <filesystem>

#include "dbacov/core/errors.h"
#include "dbacov/io/snapshot_npz.h"

namespace dbacov::app {
namespace fs = std::filesystem;

SnapshotInputs::SnapshotInputs(const std::vector<std::string>& paths) {
  for (const std::string& p : paths) {
    std::error_code ec;
    const fs::file_status st = fs::status(p, ec);
    if (ec || !fs::exists(st)) throw InputError(p + ": no such file or directory");
    if (fs::is_directory(st)) {
      const std::vector<std::string> found = io::listNpzFiles(p);
      if (found.empty()) throw InputError(p + ": directory holds no .npz snapshot");
      files_.insert(files_.end(), found.begin(), found.end());
    } else if (fs::path(p).extension() == ".npz") {
      files_.push_back(p);
    } else {
      throw InputError(p + ": not a snapshot file (expected a .npz file or a directory of them)");
    }
  }
}

void SnapshotInputs::forEach(
    const std::function<void(Snapshot&)>& process,
    const std::function<void(const std::string&, const std::string&)>& on_error) const {
  for (std::size_t n = 0; n < files_.size(); ++n) {
    Snapshot s;
    try {
      s = io::loadSnapshotNpz(files_[n], static_cast<std::int64_t>(n));
    } catch (const std::exception& e) {
      on_error(files_[n], e.what());
      continue;
    }
    process(s);
  }
}

}  // namespace dbacov::app
