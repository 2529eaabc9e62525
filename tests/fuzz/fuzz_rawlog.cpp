// libFuzzer target: the snapshot rawlog reader. The bytes are an (uncompressed) rawlog held in
// memory; RawlogSnapshotReader deserializes its objects (CObservationDbaSnapshot records, and
// whatever MRPT classes the bytes name), each snapshot is validated and, when it is valid and
// small, its covariances are computed. See fuzz_target.h for the contract.
#include <vector>

#include "dbacov/mrpt/rawlog_io.h"
#include "fuzz_target.h"

extern "C" int DBACOV_FUZZ_ENTRY(const std::uint8_t* data, std::size_t size) {
  try {
    dbacov::mrpt_bridge::RawlogSnapshotReader reader(
        "fuzz.rawlog", std::vector<unsigned char>(data, data + size), 0);
    dbacov::Snapshot s;
    for (int n = 0; n < 16 && reader.next(&s); ++n) {
      try {
        s.validate();
        dbacov::fuzz::computeCovariances(s);
      } catch (const dbacov::InputError&) {
      }
    }
  } catch (const dbacov::InputError&) {
  }
  return 0;
}
