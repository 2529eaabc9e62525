#include "dbacov/app/snapshot_inputs.h"

#include <filesystem>

#include "dbacov/core/errors.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/bridge.h"

namespace dbacov::app {
namespace fs = std::filesystem;

bool isRawlogPath(const std::string& path) {
  if (fs::path(path).extension() == ".rawlog") return true;
  // A stream without a name to go by (/dev/stdin, a pipe, a FIFO not named *.npz) can only be a
  // rawlog: an .npz (zip) must be seekable.
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  return !ec && fs::path(path).extension() != ".npz" &&
         (fs::is_fifo(st) || fs::is_character_file(st) || fs::is_socket(st));
}

SnapshotInputs::SnapshotInputs(const std::vector<std::string>& paths) {
  bool usable = false;
  for (const std::string& p : paths) {
    std::error_code ec;
    const fs::file_status st = fs::status(p, ec);
    std::string problem;
    if (ec && ec != std::errc::no_such_file_or_directory) {  // e.g. a directory on the way
      problem = p + ": cannot access: " + ec.message();      // that may not be searched
    } else if (!fs::exists(st)) {
      problem = p + ": no such file or directory";
    } else if (fs::is_directory(st)) {
      try {
        const std::vector<std::string> found = io::listNpzFiles(p);
        if (found.empty()) problem = p + ": directory holds no .npz snapshot";
        for (const std::string& f : found) entries_.push_back({f, ""});
        usable |= !found.empty();
      } catch (const InputError& e) {
        problem = e.what();
      }
    } else if (fs::path(p).extension() == ".npz" || isRawlogPath(p)) {
      entries_.push_back({p, ""});
      usable = true;
    } else {
      problem = p +
                ": not a snapshot input (expected a .npz file, a .rawlog of DBA snapshots, or "
                "a directory of .npz files)";
    }
    if (!problem.empty()) entries_.push_back({p, problem});
  }
  if (!usable)
    for (const Entry& e : entries_)
      if (!e.error.empty()) throw InputError(e.error);
}

namespace {

std::string labelClash(std::int64_t label, const std::string& first, const std::string& how_first,
                       const std::string& second, const std::string& how_second) {
  return first + " (" + how_first + ") and " + second + " (" + how_second + ") are both snapshot " +
         std::to_string(label) +
         ": the outputs name snapshots by it (the tables' snapshot column, --depth-sigma's "
         "DIR/<snapshot>_<keyframe>.npy), so one would overwrite or duplicate the other; give "
         "each snapshot a distinct 'id' (e.g. process each run on its own)";
}

std::string howLabelled(const Snapshot& s) {
  return s.id ? "id " + std::to_string(*s.id) : "position " + std::to_string(s.index) + ", no id";
}

}  // namespace

void SnapshotInputs::checkDistinctLabels() const {
  std::map<std::int64_t, std::pair<std::string, std::string>> seen;  // label → file, how
  bool positions_known = true;  // until a rawlog, whose snapshot count is unknown
  for (std::size_t k = 0; k < entries_.size(); ++k) {
    const Entry& e = entries_[k];
    if (e.error.empty() && isRawlogPath(e.path)) {
      positions_known = false;
      continue;
    }
    if (!e.error.empty()) continue;  // a failed input: no snapshot, no output
    std::optional<std::int64_t> id;
    try {
      id = io::readSnapshotId(e.path);
    } catch (const InputError&) {
      continue;  // reported by the run, as its snapshot's failure
    }
    if (!id && !positions_known) continue;
    const std::int64_t label = id ? *id : static_cast<std::int64_t>(k);
    const std::string how =
        id ? "id " + std::to_string(*id) : "position " + std::to_string(k) + ", no id";
    const auto [it, fresh] = seen.emplace(label, std::make_pair(e.path, how));
    if (!fresh)
      throw InputError(labelClash(label, it->second.first, it->second.second, e.path, how));
  }
}

void SnapshotLabels::claim(const Snapshot& s) {
  const auto [it, fresh] = taken_.emplace(s.label(), std::make_pair(s.source, howLabelled(s)));
  if (!fresh)
    throw InputError(
        labelClash(s.label(), it->second.first, it->second.second, s.source, howLabelled(s)));
}

std::size_t SnapshotInputs::knownCount() const {
  for (const Entry& e : entries_)
    if (e.error.empty() && isRawlogPath(e.path)) return 0;
  return entries_.size();
}

void SnapshotInputs::forEach(const std::function<bool(Snapshot&)>& process,
                             const std::function<bool(const SnapshotItem&)>& on_error) const {
  SnapshotStream stream(*this);
  SnapshotItem item;
  while (stream.next(&item))
    if (!(item.ok() ? process(item.snapshot) : on_error(item))) return;
}

SnapshotStream::SnapshotStream(const SnapshotInputs& inputs, bool defer_npz)
    : inputs_(inputs), defer_npz_(defer_npz) {}

SnapshotStream::~SnapshotStream() = default;

namespace {

/// Records the exception `e` as the failure of `item`.
void setError(SnapshotItem* item, const std::exception& e, const std::string& source) {
  item->error = failureMessage(e);
  item->source = source;
  item->kind = classifyFailure(e, false);
}

}  // namespace

void loadPending(SnapshotItem* item) {
  if (item->pending_npz.empty()) return;
  const std::string file = std::move(item->pending_npz);
  item->pending_npz.clear();
  try {
    item->snapshot = io::loadSnapshotNpz(file, item->pending_index);
  } catch (const std::exception& e) {
    setError(item, e, file);
  }
}

bool SnapshotStream::next(SnapshotItem* item) {
  item->error.clear();
  item->source.clear();
  item->pending_npz.clear();
  while (file_ < inputs_.entries().size()) {
    const SnapshotInputs::Entry& entry = inputs_.entries()[file_];
    const std::string& file = entry.path;
    if (!entry.error.empty()) {
      ++file_;
      ++index_;
      setError(item, InputError(entry.error), file);
      return true;
    }
    if (!isRawlogPath(file)) {
      ++file_;
      item->snapshot = Snapshot();  // none until loadPending (not a previous item's)
      item->pending_npz = file;
      item->pending_index = index_++;
      if (!defer_npz_) loadPending(item);  // else the caller's
      return true;
    }
    try {
      if (!rawlog_) {
        rawlog_ = mrpt_bridge::mrptBridge().openSnapshotRawlog(file, index_);
        rawlog_snapshots_ = 0;
      }
      if (rawlog_->next(&item->snapshot)) {
        ++rawlog_snapshots_;
        index_ = item->snapshot.index + 1;
        try {
          item->snapshot.validate();
        } catch (const std::exception& e) {
          setError(item, e, item->snapshot.source);
        }
        return true;
      }
    } catch (const std::exception& e) {
      // Unreadable file or entry: report it (it counts as the next snapshot, as a failed .npz
      // does) and go on with the next input.
      setError(item, e, file);
      rawlog_.reset();
      ++file_;
      ++index_;
      return true;
    }
    const std::size_t objects = rawlog_->objectsRead();
    rawlog_.reset();
    ++file_;
    if (rawlog_snapshots_ == 0) {
      setError(item,
               InputError(file + ": holds no DBA snapshot (" + std::to_string(objects) +
                          " objects of other classes), expected the CObservationDbaSnapshot "
                          "entries that droid2rawlog writes"),
               file);
      ++index_;
      return true;
    }
  }
  return false;
}

}  // namespace dbacov::app
