// Rawlog files (SPEC §6): gz-compressed, observations-only, written atomically; read object by
// object with errors that name the file and entry (CRawlog::loadFromRawLogFile stops silently at an
// object it cannot read, so it is not used).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mrpt/serialization/CSerializable.h>

#include "dbacov/core/snapshot.h"

namespace dbacov::io {
class AtomicOutputFile;
}
namespace mrpt::io {
class CFileGZOutputStream;
class CFileGZInputStream;
}  // namespace mrpt::io

namespace dbacov::mrpt_bridge {

/// Writes serializable objects, one after another, into a gz-compressed rawlog that appears at
/// `path` only on commit().
class RawlogWriter {
 public:
  /// Throws InputError when the output cannot be created.
  explicit RawlogWriter(const std::string& path);
  ~RawlogWriter();
  void write(const mrpt::serialization::CSerializable& object);
  std::size_t count() const { return count_; }
  /// Closes the stream and replaces `path`. Throws InputError on failure.
  void commit();

 private:
  std::string path_;
  std::unique_ptr<io::AtomicOutputFile> file_;
  std::unique_ptr<mrpt::io::CFileGZOutputStream> gz_;
  std::size_t count_ = 0;
};

/// Reads the objects of a rawlog one at a time (constant memory).
class RawlogReader {
 public:
  /// Throws InputError when the file cannot be opened.
  explicit RawlogReader(const std::string& path);
  ~RawlogReader();
  /// The next object, or nullptr at the end of the file. Throws InputError naming the file and
  /// the entry number when an object cannot be read (unknown class, truncated or corrupt data);
  /// the reader cannot continue after that.
  mrpt::serialization::CSerializable::Ptr next();
  /// Number of objects read so far.
  std::size_t count() const { return count_; }

 private:
  std::string path_;
  std::unique_ptr<mrpt::io::CFileGZInputStream> gz_;
  std::size_t count_ = 0;
};

/// The DBA snapshots of a rawlog (directly, or inside a CSensoryFrame), one at a time; objects of
/// other classes are skipped.
class RawlogSnapshotReader {
 public:
  /// Throws InputError when the file cannot be opened.
  RawlogSnapshotReader(const std::string& path, std::int64_t first_index);
  ~RawlogSnapshotReader();
  /// The next snapshot, with `source` = "<path>#<entry>" and `index` = first_index + count;
  /// false at the end. Values are not validated (Snapshot::validate is the caller's, so that one
  /// invalid snapshot does not end the file). Throws InputError as RawlogReader::next() does.
  bool next(Snapshot* out);

 private:
  std::string path_;
  RawlogReader reader_;
  std::int64_t next_index_;
  std::vector<std::pair<mrpt::serialization::CSerializable::Ptr, std::size_t>> pending_;
};

}  // namespace dbacov::mrpt_bridge
