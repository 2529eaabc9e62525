#include "dbacov/core/snapshot.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "dbacov/core/keyframe_times.h"
#include "dbacov/core/se3.h"

namespace dbacov {
namespace {

[[noreturn]] void fail(const Snapshot& s, const std::string& what) {
  throw InputError(s.source + ": " + what);
}

std::string shapeStr(std::initializer_list<std::size_t> dims) {
  std::ostringstream os;
  os << '(';
  std::size_t n = 0;
  for (std::size_t d : dims) os << (n++ ? "," : "") << d;
  os << ')';
  return os.str();
}

/// The unsigned integer of T's width and T's exponent bits: x is non-finite (±inf or NaN) exactly
/// when all of them are set.
template <typename T>
struct FloatBits;
template <>
struct FloatBits<float> {
  using U = std::uint32_t;
  static constexpr U kExponent = 0x7f800000u;
};
template <>
struct FloatBits<double> {
  using U = std::uint64_t;
  static constexpr U kExponent = 0x7ff0000000000000ull;
};

/// Index of the first non-finite value, or -1.
template <typename T>
long long firstNonFinite(const T* v, std::size_t n) {
  // Blocks of 256 tested on the bits, without a branch per value: an integer OR-reduction, which
  // the compiler vectorizes (a floating-point sum would have to stay in order, one lane at a
  // time). The block that holds a non-finite value is searched again for its first one.
  using U = typename FloatBits<T>::U;
  constexpr U kExp = FloatBits<T>::kExponent;
  constexpr std::size_t kBlock = 256;
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) {
    U bad = 0;
    for (std::size_t j = 0; j < kBlock; ++j) {
      U bits;
      std::memcpy(&bits, v + i + j, sizeof bits);
      bad |= static_cast<U>((bits & kExp) == kExp);
    }
    if (bad) break;
  }
  for (; i < n; ++i)
    if (!std::isfinite(v[i])) return static_cast<long long>(i);
  return -1;
}

/// Index of the first negative value of finite floats, or -1; *any_positive (when given) says
/// whether some value is > 0. On the bits: x < 0 when the sign is set and the magnitude is not zero
/// (-0 is not negative), x > 0 when the sign is clear and the magnitude is not zero.
long long firstNegative(const float* v, std::size_t n, bool* any_positive = nullptr) {
  constexpr std::size_t kBlock = 256;
  std::size_t i = 0;
  bool positive = false;
  for (; i + kBlock <= n; i += kBlock) {
    std::uint32_t neg = 0, pos = 0;
    for (std::size_t j = 0; j < kBlock; ++j) {
      std::uint32_t bits;
      std::memcpy(&bits, v + i + j, sizeof bits);
      neg |= static_cast<std::uint32_t>(bits > 0x80000000u);
      pos |= static_cast<std::uint32_t>(bits - 1u < 0x7fffffffu);  // 1 .. 0x7fffffff
    }
    positive |= pos != 0;
    if (neg) break;
  }
  for (; i < n; ++i) {
    if (v[i] < 0) return static_cast<long long>(i);
    positive |= v[i] > 0;
  }
  if (any_positive) *any_positive = positive;
  return -1;
}

}  // namespace

Eigen::Isometry3d Snapshot::T_cw(int k) const {
  return poseFromTQ(poses_cw.row(k).data());
}

Eigen::Isometry3d Snapshot::stereoRig() const {
  if (!stereo_rig) throw InputError(source + ": no stereo rig transform (key 'stereo_rig')");
  return poseFromTQ(stereo_rig->data());
}

Eigen::Isometry3d Snapshot::T_wc(int k) const {
  return T_cw(k).inverse();
}

void Snapshot::setT_wc(int k, const Eigen::Isometry3d& T) {
  poses_cw.row(k) = poseToTQ(T.inverse()).transpose();
}

std::vector<int> Snapshot::graphKeyframes() const {
  std::vector<char> used(numKeyframes(), 0);
  for (std::size_t e = 0; e < ii.size(); ++e) {
    used[ii[e]] = 1;
    used[jj[e]] = 1;
  }
  std::vector<int> kf;
  for (int k = 0; k < numKeyframes(); ++k)
    if (used[k]) kf.push_back(k);
  return kf;
}

std::vector<std::pair<int, int>> Snapshot::relativePairs() const {
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t e = 0; e < ii.size(); ++e)
    if (ii[e] != jj[e])  // a stereo edge relates a keyframe to itself: no relative pose
      pairs.emplace_back(static_cast<int>(std::min(ii[e], jj[e])),
                         static_cast<int>(std::max(ii[e], jj[e])));
  const std::vector<int> kf = graphKeyframes();
  for (std::size_t a = 0; a + 1 < kf.size(); ++a) pairs.emplace_back(kf[a], kf[a + 1]);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

void Snapshot::validate() const {
  const std::size_t N = poses_cw.rows(), E = ii.size(), HW = pixelsPerFrame();
  if (N == 0) fail(*this, "key 'poses' is empty: expected at least 2 keyframes");
  if (H <= 0 || W <= 0) fail(*this, "key 'disps' has an empty H×W grid");
  if (disps.size() != N * HW)
    fail(*this, "key 'disps' has " + std::to_string(disps.size()) + " values, expected " +
                    shapeStr({N, std::size_t(H), std::size_t(W)}) + " (N from 'poses')");
  if (jj.size() != E)
    fail(*this, "keys 'ii' and 'jj' differ in length (" + std::to_string(E) + " vs " +
                    std::to_string(jj.size()) + ")");
  if (E == 0) fail(*this, "keys 'ii'/'jj' are empty: the snapshot has no edges");
  for (const auto& [key, arr] :
       {std::pair<const char*, const std::vector<float>*>{"target", &target},
        {"weight", &weight}}) {
    if (arr->size() != E * 2 * HW)
      fail(*this, std::string("key '") + key + "' has " + std::to_string(arr->size()) +
                      " values, expected " + shapeStr({E, 2, std::size_t(H), std::size_t(W)}) +
                      " (E from 'ii', H×W from 'disps')");
  }
  if (tstamp.size() != N)
    fail(*this, "key 'tstamp' has " + std::to_string(tstamp.size()) + " values, expected " +
                    std::to_string(N) + " (N from 'poses')");
  if (timestamps_s && timestamps_s->size() != N)
    fail(*this, "key 'timestamps_s' has " + std::to_string(timestamps_s->size()) +
                    " values, expected " + std::to_string(N) + " (N from 'poses')");

  for (std::size_t e = 0; e < E; ++e) {
    for (const auto& [key, v] : {std::pair<const char*, std::int64_t>{"ii", ii[e]}, {"jj", jj[e]}})
      if (v < 0 || v >= static_cast<std::int64_t>(N))
        fail(*this, std::string("key '") + key + "' edge " + std::to_string(e) +
                        " names keyframe " + std::to_string(v) + ", expected 0.." +
                        std::to_string(N - 1));
    if (ii[e] == jj[e] && !stereo_rig)
      fail(*this, "edge " + std::to_string(e) + " links keyframe " + std::to_string(ii[e]) +
                      " to itself (ii == jj): a stereo edge needs the rig transform, key "
                      "'stereo_rig'");
  }
  if (disps_sens && disps_sens->size() != N * HW)
    fail(*this, "key 'disps_sens' has " + std::to_string(disps_sens->size()) +
                    " values, expected " + shapeStr({N, std::size_t(H), std::size_t(W)}) +
                    " (N from 'poses', H×W from 'disps')");
  if (stereo_rig &&
      (firstNonFinite(stereo_rig->data(), 7) >= 0 || !(stereo_rig->tail<4>().norm() > 1e-6))) {
    std::ostringstream os;
    os << "key 'stereo_rig' is [" << stereo_rig->transpose()
       << "], expected a finite pose [tx ty tz qx qy qz qw] with a unit quaternion";
    fail(*this, os.str());
  }
  if (t0 && *t0 < 0)
    fail(*this, "key 't0' is " + std::to_string(*t0) + ", expected a keyframe index >= 0");

  static const char* const kPoseColumns[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  for (std::size_t k = 0; k < N; ++k) {
    if (long long c = firstNonFinite(poses_cw.row(k).data(), 7); c >= 0)
      fail(*this, "key 'poses' keyframe " + std::to_string(k) + " has the non-finite value " +
                      std::to_string(poses_cw(k, c)) + " in column " + std::to_string(c) + " (" +
                      kPoseColumns[c] + "), expected a finite pose [tx ty tz qx qy qz qw]");
    if (poses_cw.row(k).tail<4>().norm() < 1e-6)
      fail(*this, "key 'poses' keyframe " + std::to_string(k) +
                      " has a zero quaternion, expected a unit quaternion [qx qy qz qw]");
  }
  if (firstNonFinite(intrinsics.data(), 4) >= 0 || !(intrinsics[0] > 0) || !(intrinsics[1] > 0)) {
    std::ostringstream os;
    os << "key 'intrinsics' is [fx fy cx cy] = [" << intrinsics[0] << ' ' << intrinsics[1] << ' '
       << intrinsics[2] << ' ' << intrinsics[3] << "], expected finite values with fx, fy > 0";
    fail(*this, os.str());
  }

  auto pixelOf = [&](std::size_t flat, std::size_t planes_per_item, const char* item) {
    const std::size_t plane = flat / HW, p = flat % HW;
    std::ostringstream os;
    os << item << ' ' << plane / planes_per_item;
    if (planes_per_item == 2) os << " channel " << plane % 2;
    os << " pixel (x=" << p % W << ", y=" << p / W << ")";
    return os.str();
  };
  if (long long bad = firstNonFinite(disps.data(), disps.size()); bad >= 0)
    fail(*this, "key 'disps' is non-finite at " + pixelOf(bad, 1, "keyframe"));
  if (disps_sens) {
    if (long long bad = firstNonFinite(disps_sens->data(), disps_sens->size()); bad >= 0)
      fail(*this, "key 'disps_sens' is non-finite at " + pixelOf(bad, 1, "keyframe"));
    if (long long i = firstNegative(disps_sens->data(), disps_sens->size()); i >= 0)
      fail(*this, "key 'disps_sens' is negative at " + pixelOf(i, 1, "keyframe") +
                      ", expected an inverse depth >= 0 (0 = no sensor reading)");
  }
  if (long long bad = firstNonFinite(target.data(), target.size()); bad >= 0)
    fail(*this, "key 'target' is non-finite at " + pixelOf(bad, 2, "edge"));
  if (long long bad = firstNonFinite(weight.data(), weight.size()); bad >= 0)
    fail(*this, "key 'weight' is non-finite at " + pixelOf(bad, 2, "edge"));
  bool any_weight = false;
  if (long long i = firstNegative(weight.data(), weight.size(), &any_weight); i >= 0)
    fail(*this, "key 'weight' is negative (" + std::to_string(weight[i]) + ") at " +
                    pixelOf(i, 2, "edge") + ", expected confidences >= 0");
  if (!any_weight)
    fail(*this,
         "key 'weight' is zero at every pixel of every edge: the snapshot carries no "
         "information, expected some confidences > 0");
  for (const auto& [key, times] :
       {std::pair<const char*, const std::vector<double>*>{"tstamp", &tstamp},
        {"timestamps_s", timestamps_s ? &*timestamps_s : nullptr}})
    if (long long k = times ? firstNonFinite(times->data(), times->size()) : -1; k >= 0)
      fail(*this, std::string("key '") + key + "' keyframe " + std::to_string(k) +
                      " has the non-finite value " + std::to_string((*times)[k]) +
                      ", expected a finite time");
  checkDistinctTstamps(*this);
}

double keyframeTime(const Snapshot& s, int k) {
  if (!s.timestamps_s)
    throw InputError(
        "no keyframe times: add --fps F (keyframe time = tstamp / F, F = the camera's frame "
        "rate), or dump the image times as 'timestamps_s'");
  const double t = (*s.timestamps_s)[k];
  checkRepresentableTime(t, "keyframe " + std::to_string(k) + " (tstamp " +
                                std::to_string(static_cast<long long>(s.tstamp[k])) + ")");
  return t;
}

int newestKeyframe(const Snapshot& s) {
  return s.graphKeyframes().back();
}

void deriveKeyframeTimes(Snapshot& s, double fps, double start_time) {
  if (s.timestamps_s) return;
  checkFps(fps);
  std::vector<double> t(s.tstamp.size());
  for (std::size_t k = 0; k < t.size(); ++k) t[k] = start_time + s.tstamp[k] / fps;
  s.timestamps_s = std::move(t);
}

}  // namespace dbacov
