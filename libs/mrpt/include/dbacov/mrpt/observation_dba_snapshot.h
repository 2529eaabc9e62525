// One DBA snapshot as an MRPT observation, so that snapshots travel in rawlogs (conventions §1,
// §6).
//
// Serialization (version 0): timestamp, sensorLabel, then N, H, W, E as int32, the arrays of
// conventions §1 in C order (poses as float64 T_cw, disps/target/weight float32, intrinsics
// float64, ii/jj int64, tstamp float64), and the optional timestamps_s and id behind a presence
// flag. Reading refuses declared sizes beyond kMaxSnapshotBytes before allocating, grows each array
// only with the data that really arrives (a record that declares more than the stream holds costs
// no more memory than what it holds), refuses a sensorLabel longer than 64 KiB and presence flags
// other than 0/1, and throws InputError on truncated records, naming the array. Value checks
// (Snapshot::validate) are left to the caller, so that one invalid snapshot does not stop the
// reading of a rawlog.
//
// The class is registered with MRPT's class registry when the shared library libdbacov_mrpt.so
// is loaded (a static initializer), so MRPT tools read it as a plugin:
//     rawlog-edit -p libdbacov_mrpt.so --info -i snapshots.rawlog
#pragma once

#include <cstdint>
#include <ostream>

#include <mrpt/obs/CObservation.h>
#include <mrpt/serialization/CSerializable.h>

#include "dbacov/core/snapshot.h"

namespace dbacov {

/// Upper bound on the bytes a serialized snapshot may declare (arrays included).
constexpr std::uint64_t kMaxSnapshotBytes = 8ull << 30;

class CObservationDbaSnapshot : public mrpt::obs::CObservation {
  DEFINE_SERIALIZABLE(CObservationDbaSnapshot, dbacov)

 public:
  /// The snapshot. Its `source` and `index` are not serialized (they describe where it is read).
  Snapshot snapshot;

  /// The camera has no pose relative to a robot here: identity.
  void getSensorPose(mrpt::poses::CPose3D& out_sensorPose) const override;
  void setSensorPose(const mrpt::poses::CPose3D& newSensorPose) override;
  void getDescriptionAsText(std::ostream& o) const override;
};

/// Makes sure the class is registered (it is, once the library is loaded; call this from code
/// that must not rely on load order, e.g. static executables).
void registerDbacovMrptClasses();

}  // namespace dbacov
