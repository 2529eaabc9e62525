#include "dbacov/app/evaluation_report.h"

#include <cstdio>
#include <map>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "dbacov/app/csv_format.h"
#include "dbacov/core/errors.h"

namespace dbacov::app {
namespace {

using Key = std::pair<std::int64_t, int>;  // (snapshot, keyframe)

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void printStats(std::ostream& out, const ConsistencyStats& st, const std::string& indent) {
  const auto nominal = nominalCoverage();
  out << indent << "ANEES " << fmt("%.3f", st.anees) << " (DoF " << fmt("%.2f", st.dof)
      << "), 95% region [" << fmt("%.2f", st.region.lower) << ", " << fmt("%.2f", st.region.upper)
      << "] for " << st.runs << " runs: "
      << (st.inside
              ? "inside"
              : (st.anees > st.region.upper ? "ABOVE (over-confident)" : "BELOW (under-confident)"))
      << '\n';
  out << indent << "coverage 1/2/3 sigma: " << fmt("%.1f", 100 * st.coverage_all[0]) << " / "
      << fmt("%.1f", 100 * st.coverage_all[1]) << " / " << fmt("%.1f", 100 * st.coverage_all[2])
      << " % (nominal " << fmt("%.1f", 100 * nominal[0]) << " / " << fmt("%.1f", 100 * nominal[1])
      << " / " << fmt("%.1f", 100 * nominal[2]) << ")\n";
  out << indent << "NEES above chi2(0.95): " << fmt("%.1f", 100 * st.tail_95)
      << " % of samples (nominal 5.0)\n";
  static const char* axes[6] = {"rho_x", "rho_y", "rho_z", "phi_x", "phi_y", "phi_z"};
  out << indent << "1-sigma per axis:";
  for (int i = 0; i < 6; ++i) out << ' ' << axes[i] << ' ' << fmt("%.1f", 100 * st.coverage(i, 0));
  out << " %\n";
  out << indent << "Spearman(predicted sigma, actual error): translation "
      << fmt("%.3f", st.spearman_translation) << ", rotation " << fmt("%.3f", st.spearman_rotation)
      << '\n';
}

nlohmann::json statsJson(const ConsistencyStats& st) {
  nlohmann::json per_axis = nlohmann::json::array();
  for (int i = 0; i < 6; ++i)
    per_axis.push_back({st.coverage(i, 0), st.coverage(i, 1), st.coverage(i, 2)});
  return {{"samples", st.samples},
          {"runs", st.runs},
          {"anees", st.anees},
          {"dof", st.dof},
          {"region", {st.region.lower, st.region.upper}},
          {"inside", st.inside},
          {"coverage", {st.coverage_all[0], st.coverage_all[1], st.coverage_all[2]}},
          {"coverage_per_axis", per_axis},
          {"tail_95", st.tail_95},
          {"spearman_translation", st.spearman_translation},
          {"spearman_rotation", st.spearman_rotation}};
}

bool hasSamples(const std::vector<NeesSample>& v) {
  for (const auto& x : v)
    if (x.nees.dof > 0) return true;
  return false;
}

}  // namespace

FileSamples samplesFromTables(const std::vector<KeyframeCovarianceRow>& keyframes,
                              const std::vector<RelativeCovarianceRow>& relative,
                              const GroundTruth& gt, const KeyframeTimes& times,
                              const FileSampleOptions& o) {
  FileSamples out;
  std::map<Key, const KeyframeCovarianceRow*> by_key;
  for (const auto& r : keyframes) by_key[{r.snapshot, r.keyframe}] = &r;
  // Ground truth per keyframe row (nullopt: none).
  std::map<Key, Eigen::Isometry3d> truth;
  for (const auto& r : keyframes) {
    const double t = times(r.tstamp);
    const auto T = gt.at(t, o.time_tolerance, o.max_gap);
    if (!T) {
      out.skipped.push_back(r.where + ": no ground truth at t = " + formatDouble(t) + " s in " +
                            gt.path());
      continue;
    }
    truth[{r.snapshot, r.keyframe}] = *T;
  }
  std::map<std::int64_t, double> scale;
  if (o.align_sim3) {
    std::map<std::int64_t, std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>> pts;
    for (const auto& r : keyframes)
      if (truth.count({r.snapshot, r.keyframe}))
        pts[r.snapshot].emplace_back(r.T_wc.translation(),
                                     truth[{r.snapshot, r.keyframe}].translation());
    for (const auto& [snap, p] : pts) {
      Eigen::Matrix3Xd src(3, p.size()), dst(3, p.size());
      for (std::size_t i = 0; i < p.size(); ++i) {
        src.col(i) = p[i].first;
        dst.col(i) = p[i].second;
      }
      const double spread = (src.colwise() - src.rowwise().mean()).norm();
      if (p.size() < 3 || !(spread > 1e-12)) {
        out.skipped.push_back("snapshot " + std::to_string(snap) +
                              ": fewer than 3 distinct keyframe centres, no alignment");
        continue;
      }
      const Eigen::Matrix4d S = Eigen::umeyama(src, dst, true);
      scale[snap] = S.block<3, 1>(0, 0).norm();
    }
  } else {
    for (const auto& r : keyframes) {
      const auto it = truth.find({r.snapshot, r.keyframe});
      if (it == truth.end()) continue;
      NeesSample x = makeSample(r.snapshot, "kf" + std::to_string(r.keyframe),
                                poseError(r.T_wc, it->second), r.Sigma);
      if (x.nees.dof > 0) out.absolute.push_back(std::move(x));
    }
  }
  std::map<Key, int> next;  // (snapshot, from) → smallest `to`
  for (const auto& r : relative) {
    auto [it, fresh] = next.try_emplace({r.snapshot, r.from}, r.to);
    if (!fresh) it->second = std::min(it->second, r.to);
  }
  for (const auto& r : relative) {
    if (o.consecutive_only && next[{r.snapshot, r.from}] != r.to) continue;
    const auto ta = truth.find({r.snapshot, r.from}), tb = truth.find({r.snapshot, r.to});
    if (ta == truth.end() || tb == truth.end()) {
      if (!by_key.count({r.snapshot, r.from}) || !by_key.count({r.snapshot, r.to}))
        out.skipped.push_back(r.where + ": no keyframe row (--csv) for keyframe " +
                              std::to_string(by_key.count({r.snapshot, r.from}) ? r.to : r.from) +
                              " of snapshot " + std::to_string(r.snapshot) + ", so no time");
      continue;
    }
    Eigen::Isometry3d Z = r.Z;
    Matrix6d Sigma = r.Sigma;
    if (o.align_sim3) {
      const auto s = scale.find(r.snapshot);
      if (s == scale.end()) continue;
      // A world similarity scales relative translations and their tangent ρ by s.
      Z.translation() *= s->second;
      Vector6d d;
      d << s->second, s->second, s->second, 1, 1, 1;
      Sigma = d.asDiagonal() * Sigma * d.asDiagonal();
    }
    const Eigen::Isometry3d Z_true = ta->second.inverse() * tb->second;
    NeesSample x = makeSample(r.snapshot, std::to_string(r.from) + "-" + std::to_string(r.to),
                              poseError(Z, Z_true), Sigma);
    if (x.nees.dof > 0) out.relative.push_back(std::move(x));
  }
  return out;
}

FileSamples samplesFromRawlog(const std::vector<RawlogPoseRow>& rows, const GroundTruth& gt,
                              const FileSampleOptions& o) {
  FileSamples out;
  for (const auto& r : rows) {
    const auto T = gt.at(r.t, o.time_tolerance, o.max_gap);
    if (!T) {
      out.skipped.push_back("rawlog entry " + std::to_string(r.entry) +
                            ": no ground truth at t = " + formatDouble(r.t) + " s in " + gt.path());
      continue;
    }
    NeesSample x = makeSample(static_cast<std::int64_t>(r.entry), "t" + formatDouble(r.t),
                              poseError(r.T_wc, *T), r.Sigma);
    if (x.nees.dof > 0) out.absolute.push_back(std::move(x));
  }
  return out;
}

void printReport(std::ostream& out, const std::vector<ReportSection>& sections,
                 const std::optional<Calibration>& cal) {
  for (const auto& sec : sections) {
    out << sec.title << ":";
    if (!hasSamples(sec.samples)) {
      out << " no samples\n";
      continue;
    }
    const ConsistencyStats st = summarize(sec.samples);
    out << ' ' << st.samples << " samples\n";
    printStats(out, st, "  ");
  }
  if (!cal) return;
  out << "calibration: variance inflation k = " << fmt("%.6g", cal->k)
      << (cal->fitted ? " fitted on " + cal->fitted_on + " (" + std::to_string(cal->fit_samples) +
                            " samples)"
                      : " (given)")
      << '\n';
  if (cal->weight_scale > 0)
    out << "  apply it with: dba-covariance --weight-scale "
        << fmt("%.6g", cal->calibratedWeightScale()) << "  (= " << fmt("%.6g", cal->weight_scale)
        << " / " << fmt("%.6g", cal->k) << ")\n";
  for (const auto& sec : sections) {
    if (!hasSamples(sec.samples)) continue;
    out << sec.title << ", calibrated (Sigma x k):\n";
    printStats(out, summarize(inflate(sec.samples, cal->k)), "  ");
  }
}

std::string reportJson(const std::vector<ReportSection>& sections,
                       const std::optional<Calibration>& cal) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& sec : sections) {
    if (!hasSamples(sec.samples)) {
      j[sec.key] = nullptr;
      continue;
    }
    j[sec.key] = statsJson(summarize(sec.samples));
    if (cal) j[sec.key + "_calibrated"] = statsJson(summarize(inflate(sec.samples, cal->k)));
  }
  if (cal) {
    j["calibration"] = {{"k", cal->k},
                        {"fitted", cal->fitted},
                        {"fitted_on", cal->fitted_on},
                        {"fit_samples", cal->fit_samples},
                        {"weight_scale", cal->weight_scale}};
    if (cal->weight_scale > 0)
      j["calibration"]["calibrated_weight_scale"] = cal->calibratedWeightScale();
  }
  return j.dump(2) + "\n";
}

std::string samplesCsv(const std::vector<ReportSection>& sections) {
  std::ostringstream os;
  os << "section,run,group,dof,nees";
  for (int i = 0; i < 6; ++i) os << ",e_" << i;
  for (int i = 0; i < 6; ++i) os << ",sigma_" << i;
  os << '\n';
  for (const auto& sec : sections)
    for (const auto& x : sec.samples) {
      os << sec.key << ',' << x.run << ',' << x.group << ',' << x.nees.dof << ','
         << formatDouble(x.nees.value);
      for (int i = 0; i < 6; ++i) os << ',' << formatDouble(x.e[i]);
      for (int i = 0; i < 6; ++i)
        os << ',' << formatDouble(std::sqrt(std::max(0.0, x.Sigma(i, i))));
      os << '\n';
    }
  return os.str();
}

}  // namespace dbacov::app
