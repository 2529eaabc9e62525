#include "dbacov/mrpt/observation_dba_snapshot.h"

#include <mrpt/core/initializer.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>

IMPLEMENTS_SERIALIZABLE(CObservationDbaSnapshot, mrpt::obs::CObservation, dbacov)

namespace dbacov {
namespace {

template <typename T>
void writeArray(mrpt::serialization::CArchive& out, const T* data, std::size_t n) {
  if (n) out.WriteBufferFixEndianness(data, n);
}

template <typename T>
void readArray(mrpt::serialization::CArchive& in, T* data, std::size_t n, const char* key) {
  if (n && in.ReadBufferFixEndianness(data, n) != n * sizeof(T))
    throw InputError(std::string("snapshot record truncated in '") + key + "'");
}

}  // namespace

uint8_t CObservationDbaSnapshot::serializeGetVersion() const { return 0; }

void CObservationDbaSnapshot::serializeTo(mrpt::serialization::CArchive& out) const {
  const Snapshot& s = snapshot;
  out << timestamp << sensorLabel;
  out.WriteAs<int32_t>(s.numKeyframes()).WriteAs<int32_t>(s.H).WriteAs<int32_t>(s.W);
  out.WriteAs<int32_t>(s.numEdges());
  writeArray(out, s.poses_cw.data(), static_cast<std::size_t>(s.poses_cw.size()));
  writeArray(out, s.disps.data(), s.disps.size());
  writeArray(out, s.intrinsics.data(), 4);
  writeArray(out, s.ii.data(), s.ii.size());
  writeArray(out, s.jj.data(), s.jj.size());
  writeArray(out, s.target.data(), s.target.size());
  writeArray(out, s.weight.data(), s.weight.size());
  writeArray(out, s.tstamp.data(), s.tstamp.size());
  out << static_cast<bool>(s.timestamps_s);
  if (s.timestamps_s) writeArray(out, s.timestamps_s->data(), s.timestamps_s->size());
  out << static_cast<bool>(s.id);
  if (s.id) out.WriteAs<int64_t>(*s.id);
}

void CObservationDbaSnapshot::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  if (version != 0) MRPT_THROW_UNKNOWN_SERIALIZATION_VERSION(version);
  Snapshot s;
  in >> timestamp >> sensorLabel;
  const int32_t N = in.ReadAs<int32_t>(), H = in.ReadAs<int32_t>(), W = in.ReadAs<int32_t>(),
                E = in.ReadAs<int32_t>();
  if (N < 0 || H < 0 || W < 0 || E < 0)
    throw InputError("snapshot record declares negative sizes (N=" + std::to_string(N) +
                     ", H=" + std::to_string(H) + ", W=" + std::to_string(W) +
                     ", E=" + std::to_string(E) + ")");
  // Refuse before allocating: every size below is bounded by this total.
  // (in floating point: the exact product of hostile sizes may overflow 64 bits)
  const std::uint64_t hw = std::uint64_t(H) * std::uint64_t(W);
  const double bytes = double(N) * (7 * 8 + 4 * double(hw) + 16) + double(E) * (16 + 16 * double(hw));
  if (bytes > double(kMaxSnapshotBytes))
    throw InputError("snapshot record declares " + std::to_string(static_cast<long double>(bytes)) + " bytes (N=" +
                     std::to_string(N) + ", H=" + std::to_string(H) + ", W=" + std::to_string(W) +
                     ", E=" + std::to_string(E) + "), more than the limit of " +
                     std::to_string(kMaxSnapshotBytes));
  s.H = H;
  s.W = W;
  s.poses_cw.resize(N, 7);
  readArray(in, s.poses_cw.data(), std::size_t(N) * 7, "poses");
  s.disps.resize(std::size_t(N) * hw);
  readArray(in, s.disps.data(), s.disps.size(), "disps");
  readArray(in, s.intrinsics.data(), 4, "intrinsics");
  s.ii.resize(E);
  s.jj.resize(E);
  readArray(in, s.ii.data(), s.ii.size(), "ii");
  readArray(in, s.jj.data(), s.jj.size(), "jj");
  s.target.resize(std::size_t(E) * 2 * hw);
  s.weight.resize(std::size_t(E) * 2 * hw);
  readArray(in, s.target.data(), s.target.size(), "target");
  readArray(in, s.weight.data(), s.weight.size(), "weight");
  s.tstamp.resize(N);
  readArray(in, s.tstamp.data(), s.tstamp.size(), "tstamp");
  bool has_times = false, has_id = false;
  in >> has_times;
  if (has_times) {
    s.timestamps_s.emplace(N);
    readArray(in, s.timestamps_s->data(), s.timestamps_s->size(), "timestamps_s");
  }
  in >> has_id;
  if (has_id) s.id = in.ReadAs<int64_t>();
  s.source = snapshot.source;
  s.index = snapshot.index;
  snapshot = std::move(s);
}

void CObservationDbaSnapshot::getSensorPose(mrpt::poses::CPose3D& out_sensorPose) const {
  out_sensorPose = mrpt::poses::CPose3D();
}

void CObservationDbaSnapshot::setSensorPose(const mrpt::poses::CPose3D&) {}

void CObservationDbaSnapshot::getDescriptionAsText(std::ostream& o) const {
  CObservation::getDescriptionAsText(o);
  const Snapshot& s = snapshot;
  o << "DBA snapshot";
  if (s.id) o << " id " << *s.id;
  o << ": " << s.numKeyframes() << " keyframes (" << s.graphKeyframes().size() << " in the graph), "
    << s.numEdges() << " edges, " << s.H << "x" << s.W << " grid, intrinsics fx=" << s.intrinsics[0]
    << " fy=" << s.intrinsics[1] << " cx=" << s.intrinsics[2] << " cy=" << s.intrinsics[3]
    << (s.timestamps_s ? ", with keyframe times" : ", without keyframe times") << "\n";
}

void registerDbacovMrptClasses() { mrpt::rtti::registerClass(CLASS_ID(CObservationDbaSnapshot)); }

}  // namespace dbacov

MRPT_INITIALIZER(dbacov_register_mrpt_classes) { dbacov::registerDbacovMrptClasses(); }
