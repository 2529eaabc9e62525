#include "dbacov/mrpt/rawlog_io.h"

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"
#include "mrpt_errors.h"

namespace dbacov::mrpt_bridge {

RawlogWriter::RawlogWriter(const std::string& path)
    : path_(path), file_(std::make_unique<io::AtomicOutputFile>(path)) {
  gz_ = std::make_unique<mrpt::io::CFileGZOutputStream>();
  if (!gz_->open(file_->writePath()))
    throw InputError(path_ + ": cannot open the temporary rawlog output for writing");
}

RawlogWriter::~RawlogWriter() = default;

void RawlogWriter::write(const mrpt::serialization::CSerializable& object) {
  try {
    auto arch = mrpt::serialization::archiveFrom(*gz_);
    arch << object;
  } catch (const std::exception& e) {
    throw InputError(path_ + ": writing entry " + std::to_string(count_) + " failed: " + e.what());
  }
  ++count_;
}

void RawlogWriter::commit() {
  gz_->close();
  file_->commit();
}

RawlogReader::RawlogReader(const std::string& path)
    : path_(path), gz_(std::make_unique<mrpt::io::CFileGZInputStream>()) {
  if (!gz_->open(path)) throw InputError(path + ": cannot open rawlog for reading");
}

RawlogReader::~RawlogReader() = default;

mrpt::serialization::CSerializable::Ptr RawlogReader::next() {
  auto arch = mrpt::serialization::archiveFrom(*gz_);
  try {
    mrpt::serialization::CSerializable::Ptr obj;
    arch >> obj;
    ++count_;
    return obj;
  } catch (const mrpt::serialization::CExceptionEOF&) {
    return nullptr;
  } catch (const std::exception& e) {
    throw InputError(path_ + ": entry " + std::to_string(count_) +
                     " cannot be read: " + conciseMrptMessage(e.what()));
  }
}

RawlogSnapshotReader::RawlogSnapshotReader(const std::string& path, std::int64_t first_index)
    : path_(path), reader_(path), next_index_(first_index) {}

RawlogSnapshotReader::~RawlogSnapshotReader() = default;

bool RawlogSnapshotReader::next(Snapshot* out) {
  while (true) {
    while (!pending_.empty()) {
      auto [obj, entry] = std::move(pending_.front());
      pending_.erase(pending_.begin());
      if (auto snap = std::dynamic_pointer_cast<CObservationDbaSnapshot>(obj)) {
        *out = std::move(snap->snapshot);
        out->source = path_ + "#" + std::to_string(entry);
        out->index = next_index_++;
        return true;
      }
    }
    auto obj = reader_.next();
    if (!obj) return false;
    const std::size_t entry = reader_.count() - 1;
    if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
      for (const auto& o : *sf) pending_.emplace_back(o, entry);
    } else {
      pending_.emplace_back(obj, entry);
    }
  }
}

}  // namespace dbacov::mrpt_bridge
