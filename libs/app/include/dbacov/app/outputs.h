// The outputs of `dba-covariance`, one sink per option. Every sink receives each processed
// snapshot with its covariances and makes its files appear atomically: a file is either complete
// or absent (the previous version stays untouched until commit()).
#pragma once

#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dbacov/core/covariance.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/core/sequence_graph.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/io/deferred_files.h"
#include "dbacov/mrpt/bridge.h"

namespace dbacov::app {

class OutputSink {
 public:
  virtual ~OutputSink() = default;
  /// Checks, before anything is computed or written, that the sink can take this snapshot
  /// (e.g. it has keyframe times). Throws InputError naming the snapshot otherwise.
  virtual void check(const Snapshot& /*snapshot*/) const {}
  /// Checks, once the results are computed (on any thread) and before any sink adds them, that
  /// add() can take them: throws what add() would throw for these values (e.g. std::domain_error
  /// for a pose MRPT's format cannot hold), so that a snapshot fails as a whole and no output
  /// holds part of it. add() may then fail only for I/O.
  virtual void verify(const Snapshot& /*snapshot*/, const DbaCovariance& /*cov*/) const {}
  /// Adds one snapshot's results (verified). Throws InputError on I/O failure.
  virtual void add(const Snapshot& snapshot, const DbaCovariance& cov) = 0;
  /// Makes the output appear (the last step of a run). Throws InputError on I/O failure.
  virtual void commit() = 0;
  /// True when the sink needs per-pixel depth variances (CovarianceOptions::depth_variances).
  virtual bool needsDepthVariances() const { return false; }
};

/// A text table written into an atomic output file, one snapshot's rows at a time (a write error
/// is an InputError naming the file and the system's reason, at the snapshot where it happens).
class CsvSink : public OutputSink {
 public:
  CsvSink(const std::string& path, const std::string& header);
  void commit() override;

 protected:
  void append(const std::string& rows) { file_.write(rows.data(), rows.size()); }

 private:
  io::AtomicOutputFile file_;
};

/// `--csv`: one row per (snapshot, graph keyframe), header keyframeCsvHeader(); the last column,
/// noise_model, is "self-calibrated" or "stated" (--stated-model).
class KeyframeCsvSink final : public CsvSink {
 public:
  explicit KeyframeCsvSink(const std::string& path);
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
};

/// `--relative-csv`: one row per (snapshot, pair of Snapshot::relativePairs()), header
/// relativeCsvHeader(); relative pose T_wc_from⁻¹ T_wc_to, its tangent covariance and noise_model.
class RelativeCsvSink final : public CsvSink {
 public:
  explicit RelativeCsvSink(const std::string& path);
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
};

/// `--depth-sigma DIR`: `DIR/<snapshot>_<keyframe>.npy` per source keyframe, float32 H×W standard
/// deviation of the inverse depth, NaN where a pixel carries no information. The maps are queued
/// in an unnamed spool file (io::DeferredFiles) and written, each atomically, by commit(): a run
/// that stops early (--fail-fast, a kill) writes none of them. DIR is created by commit().
class DepthSigmaSink final : public OutputSink {
 public:
  /// Fails early (InputError) when DIR cannot be created or written.
  explicit DepthSigmaSink(const std::string& dir);
  ~DepthSigmaSink() override;
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
  void commit() override;
  bool needsDepthVariances() const override { return true; }

 private:
  std::string dir_;
  std::unique_ptr<io::DeferredFiles> files_;
};

/// Checks that files can be created in directory `dir`, or, when it does not exist yet, in its
/// nearest existing ancestor (where `create_directories` would create it); returns that
/// directory. Creates nothing. Throws InputError naming `dir` and `what` otherwise.
std::string checkOutputDirectory(const std::string& dir, const std::string& what);

/// Creates `dir` (and its parents) if needed; InputError naming it and `what` otherwise.
void createOutputDirectory(const std::string& dir, const std::string& what);

enum class EmitMode {
  Latest,  ///< the newest graph keyframe of each snapshot (what an online fuser sees)
  All,     ///< every graph keyframe of every snapshot
  Final,   ///< each keyframe once (identified by its tstamp), from the last snapshot containing it
};

/// `--graph-edges`: which pose graph `--graph` writes (GraphSink).
enum class GraphEdges {
  Covisibility,       ///< the whole-sequence information on co-visible pairs (fusable)
  Chain,              ///< the same on consecutive keyframes only (fusable)
  SnapshotMarginals,  ///< per-snapshot marginal relative informations (pixels counted many times)
};
}  // namespace dbacov::app

template <>
struct dbacov::EnumNames<dbacov::app::GraphEdges> {
  static constexpr const char* what = "graph edge set";
  static constexpr std::array<std::pair<app::GraphEdges, const char*>, 3> entries{
      {{app::GraphEdges::Covisibility, "covisibility"},
       {app::GraphEdges::Chain, "chain"},
       {app::GraphEdges::SnapshotMarginals, "snapshot-marginals-not-fusable"}}};
};

template <>
struct dbacov::EnumNames<dbacov::app::EmitMode> {
  static constexpr const char* what = "emit mode";
  static constexpr std::array<std::pair<app::EmitMode, const char*>, 3> entries{
      {{app::EmitMode::Latest, "latest"},
       {app::EmitMode::All, "all"},
       {app::EmitMode::Final, "final"}}};
};

namespace dbacov::app {

/// `-o poses.rawlog`: CObservationRobotPose with a CPose3DPDFGaussian (mean T_wc, covariance
/// converted from the tangent, conventions §6) per emitted keyframe, timestamped with the keyframe
/// time, written through the MRPT bridge.
class PoseRawlogSink final : public OutputSink {
 public:
  PoseRawlogSink(const std::string& path, std::string label, EmitMode mode);
  ~PoseRawlogSink() override;
  void check(const Snapshot& snapshot) const override;
  void verify(const Snapshot& snapshot, const DbaCovariance& cov) const override;
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
  void commit() override;

 private:
  using Record = mrpt_bridge::PoseRecord;
  /// The records of the keyframes that `mode_` emits for this snapshot (keyframe, record).
  std::vector<std::pair<int, Record>> records(const Snapshot& s, const DbaCovariance& cov) const;

  std::unique_ptr<mrpt_bridge::PoseRawlogWriter> writer_;
  std::string label_;
  EmitMode mode_;
  std::map<double, Record> final_;  ///< Final mode: tstamp → newest record
};

/// `--graph PREFIX`: the pose graph of the whole processed sequence (PoseGraphBuilder):
/// PREFIX.graphbin (MRPT binary CNetworkOfPoses3DInf, every entry kept), PREFIX.graph (text laid
/// out for MRPT 2.5.8's loader), PREFIX.g2o (g2o's convention) and PREFIX.nodes.csv
/// (node,tstamp,time_s: the keyframe times that the graph formats cannot hold).
/// Edges: `chain` / `covisibility` export the whole-sequence information counted once
/// (sequence_graph.h, fusable); `snapshot-marginals-not-fusable` is the builder's graph of
/// per-snapshot marginal relative informations (the same pixels counted in many edges).
class GraphSink final : public OutputSink {
 public:
  /// Fails early (InputError) when PREFIX's directory is not writable.
  explicit GraphSink(std::string prefix, GraphEdges edges = GraphEdges::Covisibility,
                     const DbaOptions& options = DbaOptions::droid());
  void add(const Snapshot& snapshot, const DbaCovariance& cov) override;
  void commit() override;
  /// Pairs that every snapshot's gauge fixed (no information, no edge).
  std::size_t uninformativePairs() const {
    return sequence_ ? 0 : builder_.numUninformativePairs();
  }
  /// One line about the exported sequence graph (empty for the per-snapshot graph).
  const std::string& summary() const { return summary_; }

 private:
  std::string prefix_, summary_;
  GraphEdges edges_;
  DbaOptions options_;
  bool sequence_ = true;
  PoseGraphBuilder builder_;
  std::unique_ptr<SequenceProblem> problem_;
  std::string calibration_;  ///< --self-calibrate: the method
  bool depth_term_ = false;  ///< a snapshot's covariance had the depths' second-order term
};

/// snapshot,keyframe,tstamp,tx,ty,tz,qx,qy,qz,qw,log10_det,d_opt,a_opt,e_opt,log10_det_rot,
/// log10_det_trans,cov_00,...,cov_55
std::string keyframeCsvHeader();
/// snapshot,from,to,tx,ty,tz,qx,qy,qz,qw,cov_00,...,cov_55
std::string relativeCsvHeader();

}  // namespace dbacov::app
