// libFuzzer target: the .npz reader. The bytes are a .npz archive held in memory; every member is
// read and converted as a generic array (NpzReader), then the archive is loaded as a DBA snapshot
// (loadSnapshotNpzFromMemory, which validates it) and, when it is valid and small, its
// covariances are computed. See fuzz_target.h for the contract.
#include <vector>

#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "fuzz_target.h"

extern "C" int DBACOV_FUZZ_ENTRY(const std::uint8_t* data, std::size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  try {
    const dbacov::io::NpzReader npz = dbacov::io::NpzReader::fromMemory("fuzz.npz", bytes);
    for (const std::string& key : npz.keys()) {
      try {
        using DType = dbacov::io::NpyArray::DType;
        const dbacov::io::NpyArray a = npz.read(key);
        if (a.dtype == DType::Float32 || a.dtype == DType::Float64) {
          (void)dbacov::io::npyToDoubles(a, key);
          (void)dbacov::io::npyToFloats(a, key);
        } else {
          (void)dbacov::io::npyToInt64s(a, key);  // uint8 and bool are refused
        }
      } catch (const dbacov::InputError&) {
      }
    }
  } catch (const dbacov::InputError&) {
  }
  try {
    dbacov::fuzz::computeCovariances(dbacov::io::loadSnapshotNpzFromMemory("fuzz.npz", bytes, 0));
  } catch (const dbacov::InputError&) {
  }
  return 0;
}
