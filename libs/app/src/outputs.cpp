#include "dbacov/app/outputs.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "dbacov/app/csv_format.h"
#include "dbacov/app/self_calibration_options.h"
#include "dbacov/core/criteria.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/io/npy.h"

namespace dbacov::app {

std::string keyframeCsvHeader() {
  return "snapshot,keyframe,tstamp,tx,ty,tz,qx,qy,qz,qw,log10_det,d_opt,a_opt,e_opt,log10_det_rot,"
         "log10_det_trans," +
         upperTriangleNames("cov_") + ",noise_model";
}

std::string relativeCsvHeader() {
  return "snapshot,from,to,tx,ty,tz,qx,qy,qz,qw," + upperTriangleNames("cov_") + ",noise_model";
}

CsvSink::CsvSink(const std::string& path, const std::string& header) : file_(path) {
  append(header + '\n');
}

void CsvSink::commit() {
  file_.commit();
}

namespace {
/// The noise_model column: whether the covariance is self-calibrated or of the stated model.
const char* noiseModel(const DbaCovariance& cov) {
  return noiseModelName(!cov.summary().self_calibration.method.empty());
}
}  // namespace

KeyframeCsvSink::KeyframeCsvSink(const std::string& path) : CsvSink(path, keyframeCsvHeader()) {}

// The rows of one snapshot are formatted first and written together: a value that cannot be
// written (formatDouble refuses NaN) fails the snapshot without leaving part of it in the table.

void KeyframeCsvSink::add(const Snapshot& s, const DbaCovariance& cov) {
  std::ostringstream rows;
  for (int k : cov.keyframes()) {
    const Matrix6d Sigma = cov.marginal(k);
    const UncertaintyCriteria c = computeCriteria(Sigma);
    rows << s.label() << ',' << k << ',' << formatDouble(s.tstamp[k]) << ','
         << poseValues(cov.T_wc(k));
    for (double v : {c.log10_det, c.d_opt, c.a_opt, c.e_opt, c.log10_det_rot, c.log10_det_trans})
      rows << ',' << formatDouble(v);
    rows << ',' << upperTriangleValues(Sigma) << ',' << noiseModel(cov) << '\n';
  }
  append(rows.str());
}

RelativeCsvSink::RelativeCsvSink(const std::string& path) : CsvSink(path, relativeCsvHeader()) {}

void RelativeCsvSink::add(const Snapshot& s, const DbaCovariance& cov) {
  std::ostringstream rows;
  for (const auto& [a, b] : s.relativePairs())
    rows << s.label() << ',' << a << ',' << b << ','
         << poseValues(cov.T_wc(a).inverse() * cov.T_wc(b)) << ','
         << upperTriangleValues(cov.relative(a, b)) << ',' << noiseModel(cov) << '\n';
  append(rows.str());
}

std::string checkOutputDirectory(const std::string& dir, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p = fs::absolute(fs::path(dir.empty() ? "." : dir), ec);
  if (ec) throw InputError(dir + ": cannot use as the " + what + ": " + ec.message());
  // The directory itself, or the nearest ancestor that exists.
  while (!fs::exists(p, ec) && p.has_parent_path() && p.parent_path() != p) p = p.parent_path();
  if (!fs::is_directory(p, ec))
    throw InputError(dir + ": cannot use as the " + what + ": " + p.string() +
                     " exists and is not a directory");
  // Creating a scratch file checks that files can be made there (and leaves nothing behind,
  // whenever the process ends).
  const int fd = io::openScratchFile(p.string());
  if (fd < 0) {
    const int error = errno;
    throw InputError(dir + ": cannot use as the " + what + ": cannot create files in '" +
                     p.string() + "': " + std::strerror(error));
  }
  ::close(fd);
  return p.string();
}

void createOutputDirectory(const std::string& dir, const std::string& what) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw InputError(dir + ": cannot create the " + what + (ec ? ": " + ec.message() : ""));
}

DepthSigmaSink::DepthSigmaSink(const std::string& dir)
    : dir_(dir),
      files_(
          std::make_unique<io::DeferredFiles>(checkOutputDirectory(dir, "depth-sigma directory"))) {
}

DepthSigmaSink::~DepthSigmaSink() = default;

void DepthSigmaSink::add(const Snapshot& s, const DbaCovariance& cov) {
  const std::size_t H = s.H, W = s.W;
  for (int k : cov.sourceKeyframes())
    files_->add(dir_ + "/" + std::to_string(s.label()) + "_" + std::to_string(k) + ".npy",
                io::serializeNpy(io::makeNpy(cov.inverseDepthSigma(k), {H, W})));
}

void DepthSigmaSink::commit() {
  createOutputDirectory(dir_, "depth-sigma directory");
  files_->commit();
}

PoseRawlogSink::PoseRawlogSink(const std::string& path, std::string label, EmitMode mode)
    : writer_(mrpt_bridge::mrptBridge().createPoseRawlog(path)),
      label_(std::move(label)),
      mode_(mode) {}

PoseRawlogSink::~PoseRawlogSink() = default;

void PoseRawlogSink::check(const Snapshot& s) const {
  if (!s.timestamps_s)  // the rawlog's timestamps are the keyframes' times
    throw InputError(
        "-o needs keyframe times and the snapshot has none: add --fps F (keyframe time = "
        "tstamp / F, F = the camera's frame rate), or dump the image times as 'timestamps_s'");
}

std::vector<std::pair<int, PoseRawlogSink::Record>> PoseRawlogSink::records(
    const Snapshot& s, const DbaCovariance& cov) const {
  std::vector<int> kfs = cov.keyframes();
  if (mode_ == EmitMode::Latest) kfs = {newestKeyframe(s)};
  std::vector<std::pair<int, Record>> out;
  for (int k : kfs) {
    Record r;
    r.time = keyframeTime(s, k);
    r.T_wc = cov.T_wc(k);
    r.Sigma = cov.marginal(k);
    r.label = label_;
    out.emplace_back(k, std::move(r));
  }
  return out;
}

void PoseRawlogSink::verify(const Snapshot& s, const DbaCovariance& cov) const {
  // The conversion to MRPT's yaw/pitch/roll throws std::domain_error at pitch ±90°.
  for (const auto& [k, r] : records(s, cov)) mrpt_bridge::mrptBridge().checkPoseRecord(r.T_wc);
}

void PoseRawlogSink::add(const Snapshot& s, const DbaCovariance& cov) {
  // verify() has checked that every record converts: a keyframe that cannot be converted fails
  // the snapshot before any of its records reaches the rawlog.
  for (auto& [k, r] : records(s, cov)) {
    if (mode_ == EmitMode::Final)
      final_.insert_or_assign(s.tstamp[k], std::move(r));
    else
      writer_->write(r);
  }
}

void PoseRawlogSink::commit() {
  if (mode_ == EmitMode::Final) {
    std::vector<const Record*> ordered;
    for (const auto& [tstamp, r] : final_) ordered.push_back(&r);
    std::stable_sort(ordered.begin(), ordered.end(),
                     [](const Record* a, const Record* b) { return a->time < b->time; });
    for (const Record* r : ordered) writer_->write(*r);
  }
  writer_->commit();
}

namespace {
/// The topology of a whole-sequence `--graph-edges` choice.
GraphTopology graphTopology(GraphEdges edges) {
  return edges == GraphEdges::Chain ? GraphTopology::Chain : GraphTopology::Covisibility;
}
}  // namespace

GraphSink::GraphSink(std::string prefix, GraphEdges edges, const DbaOptions& options)
    : prefix_(std::move(prefix)), edges_(edges), options_(options) {
  sequence_ = edges_ != GraphEdges::SnapshotMarginals;
  if (sequence_) problem_ = std::make_unique<SequenceProblem>();
  io::AtomicOutputFile probe(prefix_ + ".graphbin");  // discarded: only checks the directory
}

void GraphSink::add(const Snapshot& s, const DbaCovariance& cov) {
  if (!sequence_) {
    builder_.add(s, cov);  // the snapshot's own covariances, self-calibrated or not
    return;
  }
  // Self-calibrated: the snapshot's flows enter the sequence at the white-noise variance factors
  // its calibration found, so that the graph's information is calibrated as the other outputs
  // are, not at the claimed weights.
  const SelfCalibrationSummary& sc = cov.summary().self_calibration;
  if (sc.method.empty() || static_cast<int>(sc.edge_factor.size()) != s.numEdges()) {
    problem_->add(s);
    return;
  }
  problem_->add(inflateWeights(s, sc.edge_factor));
  calibration_ = sc.method;
  depth_term_ = depth_term_ || sc.depth_noise_share > 0;
}

void GraphSink::commit() {
  PoseGraph g;
  if (sequence_) {
    const SequenceGraph sg = sequenceGraph(*problem_, options_, graphTopology(edges_));
    g = sg.graph;
    std::ostringstream os;
    os << "graph: " << problem_->numKeyframes() << " keyframes, " << problem_->numEdges()
       << " DBA edges (final flows) of " << problem_->numSnapshots()
       << " snapshots, re-solved: " << sg.solve.brief() << "; " << toString(edges_) << " export of "
       << sg.edges << " edges, information scale " << formatDouble(sg.scale)
       << ", KL to the dense information " << formatDouble(sg.kl) << " nats ("
       << formatDouble(sg.kl / std::max(sg.dof, 1)) << " per DoF)";
    if (!calibration_.empty()) {
      // What a weight per edge cannot carry is said: the depths' second-order term and the
      // per-edge flow field.
      os << "; self-calibrated (" << calibration_ << "): each snapshot's edges at their variance "
         << "factors";
      std::vector<std::string> left_out;
      if (depth_term_) left_out.push_back("the depths' second-order term");
      left_out.push_back("the per-edge flow field (white noise only)");
      for (std::size_t i = 0; i < left_out.size(); ++i)
        os << (i == 0 ? ", without " : " and ") << left_out[i];
    }
    summary_ = os.str();
  } else {
    g = builder_.graph();
  }
  mrpt_bridge::mrptBridge().writeGraphFiles(prefix_, g);
  io::writeFileAtomically(prefix_ + ".nodes.csv", [&](std::ostream& os) {
    os << "node,tstamp,time_s\n";
    for (const auto& [id, T] : g.nodes) {
      os << id << ',' << formatDouble(g.node_tstamp.at(id)) << ',';
      if (const auto t = g.node_time.find(id); t != g.node_time.end())
        os << formatDouble(t->second);
      os << '\n';
    }
  });
}

}  // namespace dbacov::app
