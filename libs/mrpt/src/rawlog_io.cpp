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

std::size_t forEachRawlogSnapshot(const std::string& path, std::int64_t first_index,
                                  const std::function<void(Snapshot&)>& process,
                                  const std::function<void(const InputError&)>& on_invalid) {
  RawlogReader reader(path);
  std::size_t n = 0;
  auto handle = [&](const mrpt::serialization::CSerializable::Ptr& obj, std::size_t entry) {
    auto snap = std::dynamic_pointer_cast<CObservationDbaSnapshot>(obj);
    if (!snap) return;
    snap->snapshot.source = path + "#" + std::to_string(entry);
    snap->snapshot.index = first_index + static_cast<std::int64_t>(n++);
    try {
      snap->snapshot.validate();
    } catch (const InputError& e) {
      on_invalid(e);
      return;
    }
    process(snap->snapshot);
  };
  while (auto obj = reader.next()) {
    const std::size_t entry = reader.count() - 1;
    if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
      for (const auto& o : *sf) handle(o, entry);
    } else {
      handle(obj, entry);
    }
  }
  return n;
}

}  // namespace dbacov::mrpt_bridge
