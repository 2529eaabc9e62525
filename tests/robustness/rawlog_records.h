// Hand-edited rawlog records for the robustness tests: a CObservationDbaSnapshot serialized by
// MRPT's archive (class header, version, timestamp, sensorLabel, N H W E, arrays, end flag), whose
// bytes a test may change before they are written as a gz-compressed rawlog.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <zlib.h>

#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/serialization/CArchive.h>

#include "dbacov/mrpt/observation_dba_snapshot.h"

namespace dbacov::testing {

struct RecordBytes {
  std::vector<unsigned char> bytes;  ///< one object as MRPT's archive writes it
  std::size_t label_at = 0;          ///< offset of the sensorLabel's uint32 length
  std::size_t sizes_at = 0;          ///< offset of N (then H, W, E), int32 each

  void setSizes(std::int32_t N, std::int32_t H, std::int32_t W, std::int32_t E) {
    const std::int32_t v[4] = {N, H, W, E};
    std::memcpy(&bytes[sizes_at], v, sizeof v);  // little-endian host
  }
  void setLabelLength(std::uint32_t n) { std::memcpy(&bytes[label_at], &n, 4); }
  /// Offset of the presence flag of 'timestamps_s' (the byte after the arrays before it).
  std::size_t flagAt(const Snapshot& s) const {
    const std::size_t N = s.numKeyframes(), E = s.numEdges(), HW = s.pixelsPerFrame();
    return sizes_at + 16 + N * 7 * 8 + N * HW * 4 + 4 * 8 + 2 * E * 8 + 2 * E * 2 * HW * 4 + N * 8;
  }
};

inline RecordBytes serializeRecord(const Snapshot& s, const std::string& label = "DBA_SNAPSHOT") {
  CObservationDbaSnapshot obs;
  obs.snapshot = s;
  obs.sensorLabel = label;
  obs.timestamp = mrpt::Clock::fromDouble(1000.0);
  mrpt::io::CMemoryStream mem;
  auto arch = mrpt::serialization::archiveFrom(mem);
  arch << obs;
  RecordBytes r;
  const auto* p = static_cast<const unsigned char*>(mem.getRawBufferData());
  r.bytes.assign(p, p + mem.getTotalBytesCount());
  const auto at = std::search(r.bytes.begin(), r.bytes.end(), label.begin(), label.end());
  if (at == r.bytes.end()) throw std::logic_error("serializeRecord: label not found");
  r.label_at = static_cast<std::size_t>(at - r.bytes.begin()) - 4;
  r.sizes_at = r.label_at + 4 + label.size();
  return r;
}

/// Writes `bytes` as a gz-compressed file (what rawlogs are).
inline void writeGz(const std::string& path, const std::vector<unsigned char>& bytes) {
  mrpt::io::CFileGZOutputStream out(path);
  if (!bytes.empty()) out.Write(bytes.data(), bytes.size());
}

/// `bytes` gzip-compressed up to a sync flush, without the end of the stream: what a writer that
/// flushes after every record (as a live pipe needs) leaves behind when it is killed.
inline std::vector<unsigned char> gzCutAtFlush(const std::vector<unsigned char>& bytes) {
  z_stream z{};
  deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16 /* gzip */, 8, Z_DEFAULT_STRATEGY);
  std::vector<unsigned char> out(deflateBound(&z, bytes.size()) + 64);
  z.next_in = const_cast<unsigned char*>(bytes.data());
  z.avail_in = static_cast<unsigned>(bytes.size());
  z.next_out = out.data();
  z.avail_out = static_cast<unsigned>(out.size());
  deflate(&z, Z_SYNC_FLUSH);
  out.resize(out.size() - z.avail_out);
  deflateEnd(&z);
  return out;
}

/// A rawlog holding one record of `s`, changed by `edit` first.
inline void writeRecord(const std::string& path, const Snapshot& s,
                        const std::function<void(RecordBytes&)>& edit) {
  RecordBytes r = serializeRecord(s);
  edit(r);
  writeGz(path, r.bytes);
}

}  // namespace dbacov::testing
