// One DBA snapshot of DROID-SLAM: the dense bundle adjustment factor graph at one frontend update.
//
// Layout and units follow conventions §1 exactly; this struct is the in-memory form of one `.npz`
// file.
//   poses_cw     N×7, world-to-camera T_cw as [tx ty tz qx qy qz qw] (lietorch order), double
//   disps        N×H×W inverse depth per pixel, C order (index (n*H + y)*W + x)
//   intrinsics   fx fy cx cy of the H×W grid
//   ii, jj       E edges: source keyframe ii[e] → target keyframe jj[e] (0-based into poses)
//   target       E×2×H×W predicted pixel coordinates in frame jj[e] (channel 0 = x/column, 1 =
//   y/row) weight       E×2×H×W per-pixel, per-axis confidence tstamp       N keyframe time stamps
//   (DROID's image index) timestamps_s optional, N keyframe times in seconds id           optional
//   snapshot counter
//
// Per-pixel arrays stay in single precision, as DROID produces them; everything derived from them
// is computed in double precision.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dbacov/core/errors.h"

namespace dbacov {

struct Snapshot {
  std::string source;              ///< where it came from (file path, "file#3" in a rawlog)
  std::optional<std::int64_t> id;  ///< the `id` key, when present
  std::int64_t index = 0;          ///< position in the input sequence (label when `id` is absent)

  int H = 0, W = 0;
  Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor> poses_cw;
  std::vector<float> disps;
  Eigen::Vector4d intrinsics = Eigen::Vector4d::Zero();
  std::vector<std::int64_t> ii, jj;
  std::vector<float> target, weight;
  std::vector<double> tstamp;
  std::optional<std::vector<double>> timestamps_s;
  /// RGB-D: sensor inverse depth (1/m) per pixel, N×H×W like disps, 0 = no reading (key
  /// 'disps_sens'). Adds DROID's depth-sensor factor α·(d − d_sens)² on pixels with d_sens > 0.
  std::optional<std::vector<float>> disps_sens;
  /// Stereo: the fixed transform Y = T·X of every edge with ii == jj (key 'stereo_rig',
  /// [tx ty tz qx qy qz qw]; DROID's is a translation (−0.1, 0, 0)). Required by such edges.
  std::optional<Eigen::Matrix<double, 7, 1>> stereo_rig;
  /// DROID's first optimized pose of that update, max(1, min(ii) + 1) (key 't0'): DROID held
  /// every pose below it (gauge `droid`).
  std::optional<std::int64_t> t0;

  int numKeyframes() const { return static_cast<int>(poses_cw.rows()); }
  int numEdges() const { return static_cast<int>(ii.size()); }
  std::size_t pixelsPerFrame() const { return static_cast<std::size_t>(H) * W; }

  /// Snapshot label used in outputs: `id` if present, else the position in the input.
  std::int64_t label() const { return id ? *id : index; }
  /// "SOURCE (snapshot LABEL)": how errors and warnings name the snapshot they are about.
  std::string name() const { return source + " (snapshot " + std::to_string(label()) + ")"; }

  /// The stereo rig transform (stereo_rig must be set), quaternion normalized.
  Eigen::Isometry3d stereoRig() const;

  /// Camera-to-world pose of keyframe k (the state of conventions §3), from the stored T_cw.
  Eigen::Isometry3d T_wc(int k) const;
  /// World-to-camera pose of keyframe k as stored (quaternion normalized).
  Eigen::Isometry3d T_cw(int k) const;
  /// Sets keyframe k from a camera-to-world pose (stores its inverse, quaternion with qw >= 0).
  void setT_wc(int k, const Eigen::Isometry3d& T_wc);

  /// Inverse depth of pixel (x, y) of keyframe k.
  float disp(int k, int y, int x) const {
    return disps[(static_cast<std::size_t>(k) * H + y) * W + x];
  }
  /// Channel c (0 = x, 1 = y) of the target / weight plane of edge e, H×W in C order.
  const float* targetPlane(int e, int c) const {
    return &target[(static_cast<std::size_t>(e) * 2 + c) * pixelsPerFrame()];
  }
  const float* weightPlane(int e, int c) const {
    return &weight[(static_cast<std::size_t>(e) * 2 + c) * pixelsPerFrame()];
  }

  /// Keyframes that take part in at least one edge, ascending (the "graph keyframes").
  std::vector<int> graphKeyframes() const;

  /// The keyframe pairs whose relative pose the outputs report: every co-visible pair (an edge in
  /// either direction) and every pair of consecutive graph keyframes, as (lower, higher) keyframe
  /// index, sorted, without duplicates.
  std::vector<std::pair<int, int>> relativePairs() const;

  /// Checks shapes, index ranges and values (conventions §1). Throws InputError naming `source`,
  /// the key and what was expected: inconsistent shapes, ii/jj out of range or equal (ii == jj
  /// only with stereo_rig), non-finite poses or zero-norm quaternions, non-finite
  /// intrinsics/disps/targets/weights/time stamps, negative weights, weights that are zero
  /// everywhere (no information at all), non-positive focal lengths, two keyframes with the same
  /// tstamp (keyframe_times.h).
  void validate() const;
};

/// Seconds of keyframe k: timestamps_s[k]. Throws InputError when the snapshot has no keyframe
/// times (callers add the snapshot's name), or a time MRPT cannot represent (<= 0, > 1e10 s;
/// checkRepresentableTime in keyframe_times.h, naming the snapshot and keyframe).
double keyframeTime(const Snapshot& s, int k);

/// The newest graph keyframe (highest index; DROID appends keyframes in time order).
int newestKeyframe(const Snapshot& s);

/// Fills timestamps_s = start_time + tstamp / fps when absent (DROID's tstamp is the image
/// index). std::invalid_argument unless fps is finite and positive (checkFps, keyframe_times.h).
void deriveKeyframeTimes(Snapshot& s, double fps, double start_time = 0);

}  // namespace dbacov
