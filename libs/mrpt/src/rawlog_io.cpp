#include "dbacov/mrpt/rawlog_io.h"

#include <filesystem>
#include <optional>

#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include "dbacov/io/atomic_file.h"
#include "dbacov/mrpt/mrpt_errors.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"
#include "gz_streams.h"
#include "object_guard.h"

namespace dbacov::mrpt_bridge {

RawlogWriter::RawlogWriter(const std::string& path)
    : path_(path), file_(std::make_unique<io::AtomicOutputFile>(path)) {
  gz_ = std::make_unique<GzOutputStream>(file_->writePath(), path_);
}

RawlogWriter::~RawlogWriter() = default;

void RawlogWriter::write(const mrpt::serialization::CSerializable& object) {
  if (!failure_.empty()) throw InputError(failure_);
  try {
    auto arch = mrpt::serialization::archiveFrom(*gz_);
    arch << object;
  } catch (const std::exception& e) {
    // The stream may hold part of the entry: nothing more is written, and commit() refuses.
    // (MRPT's archive wraps what the stream throws; the stream's own message is the clearer.)
    failure_ = !gz_->failure().empty()
                   ? gz_->failure() + " (at entry " + std::to_string(count_) + ")"
                   : path_ + ": writing entry " + std::to_string(count_) +
                         " failed: " + conciseMrptMessage(e.what());
    throw InputError(failure_);
  }
  ++count_;
}

void RawlogWriter::commit() {
  if (!failure_.empty()) throw InputError(failure_ + " (the rawlog is not written)");
  try {
    gz_->close();
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) + " (the rawlog is not written)");
  }
  file_->commit();
}

RawlogReader::RawlogReader(const std::string& path) : path_(path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);  // a FIFO or /dev/stdin will do
  if (ec || std::filesystem::is_directory(status))
    throw InputError(path + ": cannot open rawlog for reading: " +
                     (ec ? ec.message() : std::string("it is a directory")));
  auto gz = std::make_unique<GzInputStream>(path);
  gz_ = gz.get();
  stream_ = std::make_unique<PeekStream>(std::move(gz));
}

RawlogReader::RawlogReader(const std::string& name, std::vector<unsigned char> bytes)
    : path_(name), bytes_(std::move(bytes)) {
  auto mem = std::make_unique<mrpt::io::CMemoryStream>();
  mem->assignMemoryNotOwn(bytes_.data(), bytes_.size());
  stream_ = std::make_unique<PeekStream>(std::move(mem));
}

RawlogReader::~RawlogReader() = default;

void RawlogReader::acceptOnly(std::set<std::string> class_names) {
  accepted_ = std::move(class_names);
}

namespace {
/// Thrown with a message that names the file already (next() passes it on unchanged).
struct CompleteMessage : InputError {
  using InputError::InputError;
};
}  // namespace

std::string RawlogReader::trailingBytes(const std::string& what) {
  const std::uint64_t at = stream_->getPosition();
  const std::size_t shown = stream_->peek(8);
  std::string start;
  for (std::size_t i = 0; i < shown; ++i) {
    static const char* hex = "0123456789abcdef";
    const unsigned char c = stream_->peeked()[i];
    start += std::string(i ? " " : "") + hex[c >> 4] + hex[c & 15];
  }
  // Count them to the end (the rest of the file; in constant memory).
  std::uint64_t n = 0;
  std::vector<unsigned char> chunk(1 << 16);
  bool damaged = false;
  while (!damaged) {
    const std::size_t got = stream_->Read(chunk.data(), chunk.size());
    if (got == static_cast<std::size_t>(-1)) damaged = true;
    if (got == 0 || damaged) break;
    n += got;
  }
  const bool compressed = gz_ && gz_->compressed();
  std::string m = path_ + ": " + (damaged ? "at least " : "") + std::to_string(n) + " byte" +
                  (n == 1 ? "" : "s") + " at byte " + std::to_string(at) + " of the " +
                  (compressed ? "uncompressed data" : "file") + ", after the last object (entry " +
                  std::to_string(count_ - 1) + "), " + (n == 1 ? "is" : "are") +
                  " not a rawlog object (" + what + "; starting " + start + ")";
  if (gz_ && !gz_->failure().empty()) m += "; then " + gz_->failure();
  return m;
}

mrpt::serialization::CSerializable::Ptr RawlogReader::readObject(bool in_frame) {
  std::optional<ObjectHeader> h;
  try {
    h = peekObjectHeader(*stream_);
  } catch (const InputError& e) {
    // Past the first object, bytes that do not even start an object are what follows the last
    // one (an appended or damaged tail): say so, with where and how many.
    if (in_frame || count_ == 0 || stream_->failed()) throw;
    throw CompleteMessage(trailingBytes(e.what()));
  }
  if (!h) {
    if (in_frame) throw InputError("CSensoryFrame truncated");
    return nullptr;
  }
  if (h->short_name == "CSensoryFrame") {
    if (in_frame) throw InputError("a CSensoryFrame inside a CSensoryFrame");
    // Read here, not by MRPT, whose CSensoryFrame would trust any count.
    auto frame = mrpt::obs::CSensoryFrame::Create();
    for (std::uint32_t n = readFrameStart(*stream_, *h); n > 0; --n) {
      auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(readObject(true));
      if (!obs) throw InputError("a CSensoryFrame holds an object that is not an observation");
      frame->insert(obs);
    }
    readEndFlag(*stream_, *h);
    return frame;
  }
  if (!accepted_.empty() && !accepted_.count(h->short_name)) {
    std::string expected;
    for (const std::string& c : accepted_) expected += (expected.empty() ? "" : ", ") + c;
    throw InputError("an object of class " + printable(h->class_name) + ", expected " + expected +
                     " (plain or in CSensoryFrames)");
  }
  auto arch = mrpt::serialization::archiveFrom(*stream_);
  mrpt::serialization::CSerializable::Ptr obj;
  arch >> obj;
  // MRPT reads the class name "nullptr" as a null object: that would look like the end of the file.
  if (!obj) throw InputError("a null object (class " + printable(h->class_name) + ")");
  return obj;
}

mrpt::serialization::CSerializable::Ptr RawlogReader::next() {
  try {
    auto obj = readObject(false);
    if (obj) ++count_;
    return obj;
  } catch (const CompleteMessage&) {
    throw;
  } catch (const std::exception& e) {
    if (gz_ && !gz_->failure().empty()) {
      // Not damaged compressed data: bytes after the last gzip member, or a failing read(2).
      throw InputError(
          path_ + ": " + gz_->failure() +
          (count_ ? " (after entry " + std::to_string(count_ - 1) + ", the last complete object)"
                  : ""));
    }
    throw InputError(path_ + ": entry " + std::to_string(count_) +
                     " cannot be read: " + conciseMrptMessage(e.what()));
  }
}

RawlogSnapshotReader::RawlogSnapshotReader(const std::string& path, std::int64_t first_index)
    : path_(path), reader_(path), next_index_(first_index) {
  reader_.acceptOnly({"CObservationDbaSnapshot"});
}

RawlogSnapshotReader::RawlogSnapshotReader(const std::string& name,
                                           std::vector<unsigned char> bytes,
                                           std::int64_t first_index)
    : path_(name), reader_(name, std::move(bytes)), next_index_(first_index) {
  reader_.acceptOnly({"CObservationDbaSnapshot"});
}

RawlogSnapshotReader::~RawlogSnapshotReader() = default;

bool RawlogSnapshotReader::next(Snapshot* out) {
  while (true) {
    while (!pending_.empty()) {
      auto [obj, entry] = std::move(pending_.front());
      pending_.pop_front();
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
