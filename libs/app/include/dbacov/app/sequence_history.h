// The keyframes of a whole processed sequence, for the pictures of `dba-covariance` (--scene,
// --snapshot, --plots).
//
// A keyframe is identified over the sequence by its `tstamp` (DROID renumbers keyframes when it
// removes one; `--emit final` does the same). Which snapshot speaks for a keyframe:
//   the last processed snapshot that contains it as a graph keyframe and NOT as a gauge keyframe;
//   if every snapshot that contains it has it in its gauge, the last one that contains it.
// In DROID's sliding window every keyframe ends up among the window's two oldest, which the gauge
// fixes (the `droid` preset hard-fixes them: zero covariance); the literal "last snapshot that
// contains it" would report that fixed value for almost every keyframe. Pose, covariance and
// per-pixel maps of a keyframe always come from the same snapshot.
//
// Co-visibility: the union over the processed snapshots of the directed edges ii → jj, and the
// edges of the last processed snapshot (the current window) separately.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "dbacov/core/covariance.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::app {

struct KeyframeRecord {
  double tstamp = 0;             ///< identity over the sequence
  std::optional<double> time_s;  ///< keyframe time in seconds, when the snapshot has it
  int keyframe = 0;              ///< index into the poses of the chosen snapshot
  std::int64_t snapshot = 0;     ///< label of the chosen snapshot (Snapshot::label)
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  Matrix6d Sigma = Matrix6d::Zero();  ///< tangent covariance [ρ; φ] (conventions §3)
  bool gauge = false;                 ///< a gauge keyframe of the chosen snapshot
};

class SequenceHistory {
 public:
  /// Records the graph keyframes of one processed snapshot. Returns the keyframes (indices into
  /// `s.poses`) whose record now comes from `s`.
  std::vector<int> add(const Snapshot& s, const DbaCovariance& cov);

  /// The records in time-stamp order; position in this vector = the keyframe's sequence number.
  std::vector<KeyframeRecord> keyframes() const;
  /// Sequence number of a keyframe (position in keyframes()); −1 when unknown.
  int sequenceNumber(double tstamp) const;
  /// Directed co-visibility edges (source, target) as sequence numbers: every snapshot's, and the
  /// last processed snapshot's.
  std::vector<std::pair<int, int>> edges() const { return toNumbers(edges_); }
  std::vector<std::pair<int, int>> lastSnapshotEdges() const { return toNumbers(last_edges_); }

  std::size_t numSnapshots() const { return snapshots_; }
  std::size_t numKeyframes() const { return records_.size(); }
  /// True when every record has a time in seconds (and there is at least one).
  bool hasTimes() const;

 private:
  std::vector<std::pair<int, int>> toNumbers(const std::set<std::pair<double, double>>& e) const;

  std::map<double, KeyframeRecord> records_;
  std::set<std::pair<double, double>> edges_, last_edges_;  ///< (tstamp_i, tstamp_j)
  std::size_t snapshots_ = 0;
};

}  // namespace dbacov::app
