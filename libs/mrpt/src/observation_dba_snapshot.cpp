#include "dbacov/mrpt/observation_dba_snapshot.h"

#include <algorithm>
#include <cstdio>
#include <vector>

#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>

IMPLEMENTS_SERIALIZABLE(CObservationDbaSnapshot, mrpt::obs::CObservation, dbacov)

namespace dbacov {
namespace {

template <typename T>
void writeArray(mrpt::serialization::CArchive& out, const T* data, std::size_t n) {
  if (n) out.WriteBufferFixEndianness(data, n);
}

/// Reads `n` elements of type T for array `key`. The buffer grows with the data that really
/// arrives (16 MiB steps, then doubling), so a record that declares more than the stream holds
/// costs no more memory than what it holds.
template <typename T>
void readArray(mrpt::serialization::CArchive& in, std::vector<T>& out, std::size_t n,
               const char* key) {
  constexpr std::size_t kStep = (std::size_t{16} << 20) / sizeof(T);
  out.clear();
  while (out.size() < n) {
    const std::size_t done = out.size(), step = std::min(n - done, std::max(kStep, done));
    out.resize(done + step);
    std::size_t got = 0;
    try {
      got = in.ReadBufferFixEndianness(out.data() + done, step);
    } catch (const std::exception&) {
      got = 0;  // MRPT throws when the stream has ended
    }
    if (got > step * sizeof(T))  // the stream reported an error (e.g. damaged gz data)
      throw InputError("snapshot record unreadable in '" + std::string(key) +
                       "': the stream reports a read error (damaged compressed data?)");
    if (got != step * sizeof(T))
      throw InputError("snapshot record truncated in '" + std::string(key) + "': it declares " +
                       std::to_string(n) + " values (" + std::to_string(n * sizeof(T)) +
                       " bytes) but the stream ends after " +
                       std::to_string(done * sizeof(T) + got) + " bytes");
  }
}

/// A presence flag written as a bool: one byte that must be 0 or 1 (read as a byte, since
/// loading any other value into a bool is undefined).
bool readFlag(mrpt::serialization::CArchive& in, const char* key) {
  const auto flag = in.ReadAs<std::uint8_t>();
  if (flag > 1)
    throw InputError("snapshot record has the presence flag " + std::to_string(flag) + " for '" +
                     key + "', expected 0 or 1");
  return flag == 1;
}

/// The longest sensorLabel accepted (MRPT labels are short names).
constexpr std::uint32_t kMaxLabelBytes = 1 << 16;

/// MRPT's std::string serialization (uint32 length, then the bytes), with the length checked
/// before anything is allocated.
std::string readLabel(mrpt::serialization::CArchive& in) {
  const auto n = in.ReadAs<std::uint32_t>();
  if (n > kMaxLabelBytes)
    throw InputError("snapshot record declares a sensorLabel of " + std::to_string(n) +
                     " bytes, more than the " + std::to_string(kMaxLabelBytes) + " accepted");
  std::vector<char> bytes;
  readArray(in, bytes, n, "sensorLabel");
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

// Version 0: the monocular snapshot. Version 1 appends DROID's other modes (conventions §2): the
// depth-sensor readings (disps_sens, RGB-D), the stereo rig transform and t0 (the droid gauge),
// each behind a flag. A snapshot without them is still written as version 0, byte for byte as
// before, so that older readers open every monocular rawlog.
uint8_t CObservationDbaSnapshot::serializeGetVersion() const {
  const Snapshot& s = snapshot;
  return s.disps_sens || s.stereo_rig || s.t0 ? 1 : 0;
}

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
  if (serializeGetVersion() == 0) return;
  out << static_cast<bool>(s.disps_sens);
  if (s.disps_sens) writeArray(out, s.disps_sens->data(), s.disps_sens->size());
  out << static_cast<bool>(s.stereo_rig);
  if (s.stereo_rig) writeArray(out, s.stereo_rig->data(), 7);
  out << static_cast<bool>(s.t0);
  if (s.t0) out.WriteAs<int64_t>(*s.t0);
}

void CObservationDbaSnapshot::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  if (version > 1) MRPT_THROW_UNKNOWN_SERIALIZATION_VERSION(version);
  Snapshot s;
  in >> timestamp;
  sensorLabel = readLabel(in);
  const int32_t N = in.ReadAs<int32_t>(), H = in.ReadAs<int32_t>(), W = in.ReadAs<int32_t>(),
                E = in.ReadAs<int32_t>();
  if (N < 0 || H < 0 || W < 0 || E < 0)
    throw InputError("snapshot record declares negative sizes (N=" + std::to_string(N) +
                     ", H=" + std::to_string(H) + ", W=" + std::to_string(W) +
                     ", E=" + std::to_string(E) + ")");
  // Refuse before allocating: every size below is bounded by this total.
  // (in floating point: the exact product of hostile sizes may overflow 64 bits)
  const std::uint64_t hw = std::uint64_t(H) * std::uint64_t(W);
  const double bytes = double(N) * (7 * 8 + 4 * double(hw) * (version >= 1 ? 2 : 1) + 16) +
                       double(E) * (16 + 16 * double(hw));
  if (bytes > double(kMaxSnapshotBytes)) {
    char size[32];
    std::snprintf(size, sizeof size, "%.4g", bytes);
    throw InputError("snapshot record declares N=" + std::to_string(N) +
                     ", H=" + std::to_string(H) + ", W=" + std::to_string(W) +
                     ", E=" + std::to_string(E) + " (" + size + " bytes), more than the limit of " +
                     std::to_string(kMaxSnapshotBytes) + " bytes");
  }
  s.H = H;
  s.W = W;
  std::vector<double> poses;
  readArray(in, poses, std::size_t(N) * 7, "poses");
  s.poses_cw = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor>>(
      poses.data(), N, 7);
  readArray(in, s.disps, std::size_t(N) * hw, "disps");
  std::vector<double> intrinsics;
  readArray(in, intrinsics, 4, "intrinsics");
  s.intrinsics = Eigen::Vector4d(intrinsics.data());
  readArray(in, s.ii, std::size_t(E), "ii");
  readArray(in, s.jj, std::size_t(E), "jj");
  readArray(in, s.target, std::size_t(E) * 2 * hw, "target");
  readArray(in, s.weight, std::size_t(E) * 2 * hw, "weight");
  readArray(in, s.tstamp, std::size_t(N), "tstamp");
  if (readFlag(in, "timestamps_s"))
    readArray(in, s.timestamps_s.emplace(), std::size_t(N), "timestamps_s");
  if (readFlag(in, "id")) s.id = in.ReadAs<int64_t>();
  if (version >= 1) {
    if (readFlag(in, "disps_sens"))
      readArray(in, s.disps_sens.emplace(), std::size_t(N) * hw, "disps_sens");
    if (readFlag(in, "stereo_rig")) {
      std::vector<double> rig;
      readArray(in, rig, 7, "stereo_rig");
      s.stereo_rig = Eigen::Map<const Eigen::Matrix<double, 7, 1>>(rig.data());
    }
    if (readFlag(in, "t0")) s.t0 = in.ReadAs<int64_t>();
  }
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
    << (s.timestamps_s ? ", with keyframe times" : ", without keyframe times");
  if (s.stereo_rig) o << ", stereo rig";
  if (s.disps_sens) o << ", depth-sensor readings";
  if (s.t0) o << ", t0 = " << *s.t0;
  o << "\n";
}

void registerDbacovMrptClasses() {
  mrpt::rtti::registerClass(CLASS_ID(CObservationDbaSnapshot));
}

namespace {
// Registers the class when the library is loaded (also by dlopen, as MRPT's `-p` plugin option
// does). Not MRPT_INITIALIZER: that is __attribute__((constructor)), whose order relative to this
// file's C++ initializers is the compiler's choice; clang runs it before runtimeClassId above is
// initialized, and the class stayed unregistered. C++ initializes the variables of one file in
// order of definition, so this one runs after IMPLEMENTS_SERIALIZABLE's.
[[maybe_unused]] const bool kRegistered = (registerDbacovMrptClasses(), true);
}  // namespace

}  // namespace dbacov
