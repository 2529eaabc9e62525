#include "dbacov/app/evaluation_inputs.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include "dbacov/core/errors.h"
#include "dbacov/mrpt/bridge.h"
#include "evaluation_input_checks.h"

namespace dbacov::app {
namespace {

std::ifstream openText(const std::string& path, const char* what) {
  std::ifstream f(path);
  if (!f) throw InputError(path + ": cannot open the " + what);
  return f;
}

/// What a blank line may hold: the characters that `istream >> string` skips (a line of vertical
/// tabs split into no field at all, and an image-time list then read field 0 of none:
/// fuzz_ground_truth).
constexpr const char* kBlank = " \t\r\n\v\f";

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  if (sep == ' ') {
    std::istringstream is(line);
    for (std::string x; is >> x;) out.push_back(x);
    return out;
  }
  std::istringstream is(line);
  for (std::string x; std::getline(is, x, sep);) {
    x.erase(0, x.find_first_not_of(" \t\r"));
    x.erase(x.find_last_not_of(" \t\r") + 1);
    out.push_back(x);
  }
  return out;
}

double number(const std::string& s, const std::string& where, const std::string& column) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE || std::isnan(v))
    throw InputError(where + ": column '" + column + "': expected a number, found '" + s + "'");
  // No value of these files is infinite: an infinite time was accepted as an image time, and an
  // infinite quaternion entry passed the norm check and became a NaN rotation (fuzz_ground_truth).
  if (!std::isfinite(v))
    throw InputError(where + ": column '" + column + "': expected a finite number, found '" + s +
                     "'");
  return v;
}

Eigen::Isometry3d pose(const double* tq, const std::string& where) {
  const double n = std::sqrt(tq[3] * tq[3] + tq[4] * tq[4] + tq[5] * tq[5] + tq[6] * tq[6]);
  if (!(n > 1e-6) || !std::isfinite(tq[0] + tq[1] + tq[2]))
    throw InputError(where + ": expected a finite position and a unit quaternion");
  return poseFromTQ(tq);
}

/// A CSV table written by dba-covariance: header names → column index.
class CsvTable {
 public:
  CsvTable(const std::string& path, const std::vector<std::string>& required)
      : path_(path), f_(openText(path, "table")) {
    std::string header;
    if (!std::getline(f_, header)) throw InputError(path + ": empty file, expected a header line");
    const auto names = split(header, ',');
    for (std::size_t i = 0; i < names.size(); ++i) col_[names[i]] = i;
    for (const auto& r : required)
      if (!col_.count(r)) throw InputError(path + ":1: header has no column '" + r + "'");
    width_ = names.size();
  }
  /// The next row, false at the end.
  bool next() {
    std::string line;
    while (std::getline(f_, line)) {
      ++line_;
      if (line.find_first_not_of(kBlank) == std::string::npos) continue;
      fields_ = split(line, ',');
      if (fields_.size() != width_)
        throw InputError(where() + ": " + std::to_string(fields_.size()) + " fields, expected " +
                         std::to_string(width_));
      return true;
    }
    return false;
  }
  double get(const std::string& name) const {
    return number(fields_[col_.at(name)], where(), name);
  }
  std::string where() const { return path_ + ":" + std::to_string(line_ + 1); }
  Eigen::Isometry3d pose() const {
    const double tq[7] = {get("tx"), get("ty"), get("tz"), get("qx"),
                          get("qy"), get("qz"), get("qw")};
    return app::pose(tq, where());
  }
  Matrix6d covariance() const {
    Matrix6d S;
    for (int r = 0; r < 6; ++r)
      for (int c = r; c < 6; ++c)
        S(r, c) = S(c, r) = get("cov_" + std::to_string(r) + std::to_string(c));
    if (!S.allFinite()) throw InputError(where() + ": non-finite covariance");
    detail::checkCovarianceValues(S, where());
    return S;
  }

 private:
  std::string path_;
  std::ifstream f_;
  std::map<std::string, std::size_t> col_;
  std::size_t width_ = 0, line_ = 0;
  std::vector<std::string> fields_;
};

std::vector<std::string> covarianceColumns(std::vector<std::string> names) {
  for (const char* c : {"tx", "ty", "tz", "qx", "qy", "qz", "qw"}) names.push_back(c);
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) names.push_back("cov_" + std::to_string(r) + std::to_string(c));
  return names;
}

}  // namespace

GroundTruthFormat parseGroundTruthFormat(const std::string& name) {
  if (name == "auto") return GroundTruthFormat::Auto;
  if (name == "tum") return GroundTruthFormat::Tum;
  if (name == "euroc") return GroundTruthFormat::Euroc;
  throw std::invalid_argument("unknown ground-truth format '" + name +
                              "', expected auto, tum or euroc");
}

GroundTruth GroundTruth::load(const std::string& path, GroundTruthFormat format) {
  std::ifstream f = openText(path, "ground truth");
  GroundTruth gt;
  gt.path_ = path;
  std::vector<std::pair<double, Eigen::Isometry3d>> rows;
  std::size_t n = 0;
  for (std::string line; std::getline(f, line);) {
    ++n;
    const std::size_t first = line.find_first_not_of(kBlank);
    if (first == std::string::npos || line[first] == '#') continue;
    if (format == GroundTruthFormat::Auto)
      format =
          line.find(',') != std::string::npos ? GroundTruthFormat::Euroc : GroundTruthFormat::Tum;
    const std::string where = path + ":" + std::to_string(n);
    const bool euroc = format == GroundTruthFormat::Euroc;
    const auto v = split(line, euroc ? ',' : ' ');
    if (v.size() < 8)
      throw InputError(
          where + ": " + std::to_string(v.size()) + " fields, expected " +
          (euroc ? "timestamp[ns], px, py, pz, qw, qx, qy, qz, ..." : "t tx ty tz qx qy qz qw"));
    double x[8];
    for (int i = 0; i < 8; ++i) x[i] = number(v[i], where, "field " + std::to_string(i + 1));
    double tq[7] = {x[1], x[2], x[3], x[4], x[5], x[6], x[7]};
    if (euroc) {  // qw first in EuRoC
      tq[3] = x[5];
      tq[4] = x[6];
      tq[5] = x[7];
      tq[6] = x[4];
    }
    rows.emplace_back(euroc ? x[0] * 1e-9 : x[0], pose(tq, where));
    if (!std::isfinite(rows.back().first))
      throw InputError(where + ": the timestamp is not a finite number");
  }
  if (rows.empty()) throw InputError(path + ": no poses");
  std::stable_sort(rows.begin(), rows.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  detail::checkGroundTruthTimes(path, rows);
  for (auto& [t, T] : rows) {
    gt.t_.push_back(t);
    gt.T_.push_back(T);
  }
  return gt;
}

void GroundTruth::applyBodyToCamera(const Eigen::Isometry3d& T_bc) {
  for (auto& T : T_) T = T * T_bc;
}

std::optional<Eigen::Isometry3d> GroundTruth::at(double t, double tolerance, double max_gap) const {
  const auto it = std::lower_bound(t_.begin(), t_.end(), t);
  const std::size_t hi = it - t_.begin();
  if (hi < t_.size() && t_[hi] - t <= tolerance) return T_[hi];
  if (hi > 0 && t - t_[hi - 1] <= tolerance) return T_[hi - 1];
  if (hi == 0 || hi == t_.size() || t_[hi] - t_[hi - 1] > max_gap) return std::nullopt;
  const double a = (t - t_[hi - 1]) / (t_[hi] - t_[hi - 1]);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = (1 - a) * T_[hi - 1].translation() + a * T_[hi].translation();
  T.linear() = Eigen::Quaterniond(T_[hi - 1].linear())
                   .slerp(a, Eigen::Quaterniond(T_[hi].linear()))
                   .toRotationMatrix();
  return T;
}

KeyframeTimes KeyframeTimes::fromRate(double fps, double start) {
  if (!(fps > 0 && std::isfinite(fps)) || !std::isfinite(start))
    throw std::invalid_argument("--fps must be > 0 and --start-time finite");
  KeyframeTimes k;
  k.fps_ = fps;
  k.start_ = start;
  return k;
}

KeyframeTimes KeyframeTimes::fromFile(const std::string& path) {
  std::ifstream f = openText(path, "image time list");
  KeyframeTimes k;
  k.path_ = path;
  std::size_t n = 0;
  for (std::string line; std::getline(f, line);) {
    ++n;
    const std::size_t first = line.find_first_not_of(kBlank);
    if (first == std::string::npos || line[first] == '#') continue;
    const bool csv = line.find(',') != std::string::npos;
    const auto v = split(line, csv ? ',' : ' ');
    const double t = number(v[0], path + ":" + std::to_string(n), "time");
    k.times_.push_back(csv ? t * 1e-9 : t);
  }
  if (k.times_.empty()) throw InputError(path + ": no image times");
  return k;
}

double KeyframeTimes::operator()(double tstamp) const {
  if (times_.empty()) return start_ + tstamp / fps_;
  const double i = std::round(tstamp);
  if (std::abs(i - tstamp) > 1e-6 || i < 0 || i >= static_cast<double>(times_.size()))
    throw InputError(path_ + ": keyframe tstamp " + std::to_string(tstamp) +
                     " is not an image index 0.." + std::to_string(times_.size() - 1));
  return times_[static_cast<std::size_t>(i)];
}

namespace {

/// (snapshot, keyframe or from, to) of a table row.
using RowKey = std::tuple<std::int64_t, std::int64_t, std::int64_t>;

/// A key seen twice would be scored twice (and with two different covariances, one of them
/// against the wrong ground truth): the sign of two inputs with one snapshot id in one run.
void refuseRepeatedKey(std::map<RowKey, std::string>* seen, const RowKey& key,
                       const std::string& where, const std::string& what) {
  const auto [it, fresh] = seen->emplace(key, where);
  if (!fresh)
    throw InputError(where + ": " + what + " is already at " + it->second +
                     ": each key may appear once (were two inputs with one snapshot id "
                     "processed in one run? give each snapshot a distinct id)");
}

}  // namespace

std::vector<KeyframeCovarianceRow> readKeyframeCsv(const std::string& path) {
  CsvTable t(path, covarianceColumns({"snapshot", "keyframe", "tstamp"}));
  std::vector<KeyframeCovarianceRow> rows;
  std::map<RowKey, std::string> seen;
  while (t.next()) {
    KeyframeCovarianceRow r;
    r.snapshot = static_cast<std::int64_t>(t.get("snapshot"));
    r.keyframe = static_cast<int>(t.get("keyframe"));
    r.tstamp = t.get("tstamp");
    refuseRepeatedKey(
        &seen, {r.snapshot, r.keyframe, 0}, t.where(),
        "snapshot " + std::to_string(r.snapshot) + ", keyframe " + std::to_string(r.keyframe));
    r.T_wc = t.pose();
    r.Sigma = t.covariance();
    r.where = t.where();
    rows.push_back(std::move(r));
  }
  return rows;
}

std::vector<RelativeCovarianceRow> readRelativeCsv(const std::string& path) {
  CsvTable t(path, covarianceColumns({"snapshot", "from", "to"}));
  std::vector<RelativeCovarianceRow> rows;
  std::map<RowKey, std::string> seen;
  while (t.next()) {
    RelativeCovarianceRow r;
    r.snapshot = static_cast<std::int64_t>(t.get("snapshot"));
    r.from = static_cast<int>(t.get("from"));
    r.to = static_cast<int>(t.get("to"));
    refuseRepeatedKey(&seen, {r.snapshot, r.from, r.to}, t.where(),
                      "snapshot " + std::to_string(r.snapshot) + ", pair " +
                          std::to_string(r.from) + " -> " + std::to_string(r.to));
    r.Z = t.pose();
    r.Sigma = t.covariance();
    r.where = t.where();
    rows.push_back(std::move(r));
  }
  return rows;
}

std::vector<RawlogPoseRow> readPoseRawlog(const std::string& path, const std::string& label) {
  std::vector<RawlogPoseRow> rows;
  for (const mrpt_bridge::PoseRecord& p : mrpt_bridge::mrptBridge().readPoseRawlog(path, label)) {
    RawlogPoseRow r;
    r.entry = p.entry;
    r.t = p.time;
    r.T_wc = p.T_wc;
    r.Sigma = p.Sigma;
    detail::checkCovarianceValues(r.Sigma, path + ": entry " + std::to_string(p.entry));
    rows.push_back(r);
  }
  return rows;
}

}  // namespace dbacov::app
