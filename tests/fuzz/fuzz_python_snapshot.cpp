// libFuzzer target: the C++ entry of Python's Snapshot(...) constructor (and of dbacov.from_droid,
// which ends in it), python/src/snapshot_arrays.h. The bytes are the array arguments with their
// dtypes and shapes (python_snapshot_codec.h); a snapshot that builds and validates has its
// covariances computed when small. See fuzz_target.h for the contract.
#include "fuzz_target.h"
#include "python_snapshot_codec.h"

extern "C" int DBACOV_FUZZ_ENTRY(const std::uint8_t* data, std::size_t size) {
  const auto decoded = dbacov::fuzz::decodeSnapshotArrays(data, size);
  if (!decoded) return 0;
  try {
    dbacov::fuzz::computeCovariances(dbacov::python::snapshotFromArrays(decoded->arrays));
  } catch (const dbacov::InputError&) {
  }
  return 0;
}
