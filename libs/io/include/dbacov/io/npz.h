// NumPy `.npz` archives (np.savez / np.savez_compressed): a zip of `<key>.npy` members.
//
// NpzReader contract:
//   - opens the zip read-only (libzip); a missing file, a non-zip file or a damaged central
//     directory throws dbacov::InputError naming the path and libzip's reason;
//   - keys() lists the members that end in ".npy", without that suffix, in archive order; other
//     members and directories are ignored;
//   - read(key) accepts stored and deflated members only (what NumPy writes; encrypted members and
//     other methods are refused). Before allocating anything it checks the member's uncompressed
//     size against `max_entry_bytes` (default 4 GiB), against the plausible size for its
//     compressed size (equal when stored, at most deflate's 1032:1 ratio when deflated), and the
//     .npy header's declared shape × itemsize against the member size; the CRC is verified at the
//     end. Every error names the archive path and the key: "droid.npz: key 'target': ...".
//     Members are inflated whole with libdeflate (CRC-32 checked on the whole member); a member
//     that fails is read again through libzip's stream, whose message says where it breaks.
//   - readAll(keys) reads several members: the raw bytes in order, then inflation and parsing in
//     parallel (dbacov::parallelFor, within the ThreadLimit); it reports the failure that reading
//     the keys one by one would report first. Before any of that, the members' declared
//     uncompressed sizes together must fit the memory budget (memory_budget.h); the message says
//     how much they declare and which member is the largest.
//   - Not thread-safe (one libzip handle); use one reader per thread.
//
// NpzWriter contract: collects arrays, then commit() writes the archive atomically (see
// AtomicOutputFile): members `<key>.npy` in insertion order, each deflated (compressed = true,
// like np.savez_compressed) or stored (like np.savez), with the fixed DOS time 1980-01-01 00:00 as
// NumPy writes, so equal inputs give identical files. The archive is built in memory first (the
// arrays plus the zip: about twice the data). On failure nothing is written and the previous
// file is untouched; errors throw InputError naming the path.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dbacov/io/npy.h"

namespace dbacov::io {

class NpzReader {
 public:
  /// Largest uncompressed member accepted by default.
  static constexpr std::uint64_t kDefaultMaxEntryBytes = std::uint64_t{4} << 30;

  /// Opens `path`. Throws InputError if it cannot be opened or is not a zip archive.
  explicit NpzReader(const std::string& path,
                     std::uint64_t max_entry_bytes = kDefaultMaxEntryBytes);
  /// Reads an archive held in memory (the same checks; `name` stands for the path in messages).
  /// Used by the fuzz targets and by callers that already hold the bytes.
  static NpzReader fromMemory(const std::string& name, std::vector<unsigned char> bytes,
                              std::uint64_t max_entry_bytes = kDefaultMaxEntryBytes);
  ~NpzReader();
  NpzReader(NpzReader&&) noexcept;
  NpzReader& operator=(NpzReader&&) noexcept;
  NpzReader(const NpzReader&) = delete;
  NpzReader& operator=(const NpzReader&) = delete;

  const std::string& path() const;
  /// Array names (members ending in ".npy", suffix removed), in archive order.
  std::vector<std::string> keys() const;
  /// True if the member `<key>.npy` exists.
  bool has(const std::string& key) const;
  /// Reads and parses `<key>.npy`. Throws InputError naming path and key if it is missing,
  /// too large, damaged (CRC, truncated) or not an accepted .npy array (see npy.h).
  NpyArray read(const std::string& key) const;
  /// read() of every key, the members inflated in parallel; results in the order of `keys`.
  std::vector<NpyArray> readAll(const std::vector<std::string>& keys) const;

 private:
  /// InputError when the members `keys` declare more than memoryBudget() allows together.
  void checkBudget(const std::vector<std::string>& keys) const;
  /// InputError when two members share a name (constructors call it).
  void checkUniqueMembers() const;
  struct Impl;
  struct RawMember;
  RawMember fetch(const std::string& key) const;  ///< checks, then the member's raw bytes
  /// Inflates, verifies and parses (thread-safe); nullopt when the member is damaged.
  static std::optional<NpyArray> decode(RawMember m);
  /// Reads a damaged member through libzip's stream, for its precise message; always throws.
  NpyArray readStreaming(const std::string& key) const;
  explicit NpzReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

class NpzWriter {
 public:
  /// An empty archive destined for `path`; nothing is touched on disk before commit().
  explicit NpzWriter(std::string path, bool compressed = true);

  /// Adds `array` as member `<key>.npy`. Throws std::invalid_argument for an empty or duplicate
  /// key, or an inconsistent array; std::logic_error after commit().
  void add(const std::string& key, const NpyArray& array);

  /// Builds the zip and atomically replaces `path` with it. Throws InputError (naming the path and,
  /// when it applies, the key) if the archive cannot be built or written; std::logic_error if
  /// called twice.
  void commit();

 private:
  std::string path_;
  bool compressed_;
  bool committed_ = false;
  std::vector<std::pair<std::string, std::vector<unsigned char>>> members_;  // name, .npy bytes
};

}  // namespace dbacov::io
