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
  SnapshotStream stream(*this);
  SnapshotItem item;
  while (stream.next(&item)) {
    if (item.ok())
      process(item.snapshot);
    else
      on_error(item.error);
  }
}

SnapshotStream::SnapshotStream(const SnapshotInputs& inputs) : inputs_(inputs) {}

SnapshotStream::~SnapshotStream() = default;

bool SnapshotStream::next(SnapshotItem* item) {
  item->error.clear();
  while (file_ < inputs_.files().size()) {
    const std::string& file = inputs_.files()[file_];
    if (!isRawlogPath(file)) {
      ++file_;
      try {
        item->snapshot = io::loadSnapshotNpz(file, index_++);
      } catch (const std::exception& e) {
        item->error = e.what();
      }
      return true;
    }
    try {
      if (!rawlog_) rawlog_ = std::make_unique<mrpt_bridge::RawlogSnapshotReader>(file, index_);
      if (rawlog_->next(&item->snapshot)) {
        index_ = item->snapshot.index + 1;
        try {
          item->snapshot.validate();
        } catch (const InputError& e) {
          item->error = e.what();
        }
        return true;
      }
    } catch (const InputError& e) {
      item->error = e.what();  // unreadable file or entry: report it and go on with the next input
      rawlog_.reset();
      ++file_;
      return true;
    }
    rawlog_.reset();
    ++file_;
  }
  return false;
}

}  // namespace dbacov::app
