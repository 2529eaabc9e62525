#include "dbacov/mrpt/rawlog_io.h"

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <sstream>

#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"

namespace dbacov::mrpt_bridge {
namespace {

/// MRPT exceptions carry a banner, the location and a stack trace; keep the messages only.
std::string conciseMrptMessage(const std::string& what) {
  std::istringstream in(what);
  std::string out;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Location:", 0) == 0 || line.rfind("Call stack", 0) == 0) break;
    if (line.empty() || line.rfind("====", 0) == 0 || line == "Original exception:") continue;
    if (line.rfind("Message:", 0) == 0) line = line.substr(8);
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    if (!out.empty()) out += ": ";
    out += line.substr(first);
  }
  return out.empty() ? what : out;
}

}  // namespace

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
