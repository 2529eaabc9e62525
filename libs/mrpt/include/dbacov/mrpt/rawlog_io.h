// Rawlog files (conventions §6): gz-compressed, observations-only, written atomically; read object
// by object with errors that name the file and entry (CRawlog::loadFromRawLogFile stops silently at
// an object it cannot read, so it is not used).
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <mrpt/serialization/CSerializable.h>

#include "dbacov/core/snapshot.h"

namespace dbacov::io {
class AtomicOutputFile;
}
namespace mrpt::io {
class CStream;
}  // namespace mrpt::io

namespace dbacov::mrpt_bridge {

class GzInputStream;
class GzOutputStream;
class PeekStream;

/// Writes serializable objects, one after another, into a gz-compressed rawlog that appears at
/// `path` only on commit().
class RawlogWriter {
 public:
  /// Throws InputError when the output cannot be created.
  explicit RawlogWriter(const std::string& path);
  ~RawlogWriter();
  /// Appends `object`. Throws InputError when it cannot be written; after that the writer is
  /// failed (the stream may hold part of an entry): write() and commit() throw too.
  void write(const mrpt::serialization::CSerializable& object);
  std::size_t count() const { return count_; }
  /// Closes the stream and replaces `path`. Throws InputError on failure.
  void commit();

 private:
  std::string failure_;  ///< set by a failed write()
  std::string path_;
  std::unique_ptr<io::AtomicOutputFile> file_;
  std::unique_ptr<GzOutputStream> gz_;
  std::size_t count_ = 0;
};

/// Reads the objects of a rawlog one at a time (constant memory), from any readable path (a
/// gz-compressed or plain file, a FIFO, /dev/stdin). MRPT's deserializers trust the sizes they
/// read, so the reader looks at each object's header first: it reads CSensoryFrame containers
/// itself (at most 2^16 observations each, no frame inside a frame) and, after acceptOnly(),
/// lets MRPT deserialize only the classes named there.
class RawlogReader {
 public:
  /// Throws InputError when the file cannot be opened.
  explicit RawlogReader(const std::string& path);
  /// Reads an uncompressed rawlog held in memory (`name` stands for the path in messages).
  RawlogReader(const std::string& name, std::vector<unsigned char> bytes);
  ~RawlogReader();
  /// The next object, or nullptr at the end of the file (only at an object boundary, and for a
  /// gz-compressed file only after its last gzip member). Throws InputError naming the file and
  /// the entry number when an object cannot be read (unknown class, truncated or corrupt data);
  /// the reader cannot continue after that. Bytes after the last object that do not start one
  /// (trailing garbage, which CRawlog and zlib would ignore) are refused: "<file>: N bytes at byte
  /// X of the (uncompressed) data, after the last object (entry k), are not a rawlog object", or,
  /// outside the compressed data, "<file>: N bytes at byte X of the file, after the last gzip
  /// member, are not gzip data".
  mrpt::serialization::CSerializable::Ptr next();
  /// Number of objects read so far.
  std::size_t count() const { return count_; }
  /// Classes (names without namespace) whose objects may be read, alone or in CSensoryFrames;
  /// next() refuses any other with InputError. Empty (the default): every registered class.
  void acceptOnly(std::set<std::string> class_names);

 private:
  mrpt::serialization::CSerializable::Ptr readObject(bool in_frame);
  /// After peekObjectHeader failed at the top level, past the first object: bytes that are not an
  /// object follow the last one. Returns the message (it consumes the rest of the stream).
  std::string trailingBytes(const std::string& what);

  std::string path_;
  GzInputStream* gz_ = nullptr;       ///< the file's stream (inside stream_), when read from a file
  std::vector<unsigned char> bytes_;  ///< the rawlog, when read from memory
  std::unique_ptr<PeekStream> stream_;
  std::set<std::string> accepted_;
  std::size_t count_ = 0;
};

/// The DBA snapshots of a rawlog (directly, or inside a CSensoryFrame), one at a time. Objects of
/// other classes are refused (InputError naming the entry and class) rather than deserialized:
/// snapshot rawlogs (droid2rawlog, simul-dba --rawlog) hold nothing else, and MRPT's
/// deserializers would trust whatever sizes a damaged file declares.
class RawlogSnapshotReader {
 public:
  /// Throws InputError when the file cannot be opened.
  RawlogSnapshotReader(const std::string& path, std::int64_t first_index);
  /// Reads the snapshots of an uncompressed rawlog held in memory (see RawlogReader).
  RawlogSnapshotReader(const std::string& name, std::vector<unsigned char> bytes,
                       std::int64_t first_index);
  ~RawlogSnapshotReader();
  /// The next snapshot, with `source` = "<path>#<entry>" and `index` = first_index + count;
  /// false at the end. Values are not validated (Snapshot::validate is the caller's, so that one
  /// invalid snapshot does not end the file). Throws InputError as RawlogReader::next() does.
  bool next(Snapshot* out);
  /// Objects read so far (snapshots and objects of other classes).
  std::size_t objectsRead() const { return reader_.count(); }

 private:
  std::string path_;
  RawlogReader reader_;
  std::int64_t next_index_;
  std::deque<std::pair<mrpt::serialization::CSerializable::Ptr, std::size_t>> pending_;
};

}  // namespace dbacov::mrpt_bridge
