// The NEES samples that `dba-evaluate` builds from covariance files and ground truth, and its
// reports (text, JSON, per-sample CSV). Statistics: core/consistency.h.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "dbacov/app/evaluation_inputs.h"
#include "dbacov/sim/consistency.h"

namespace dbacov::app {

struct FileSampleOptions {
  double time_tolerance = 1e-3;  ///< seconds: a ground-truth sample this close is taken as is
  double max_gap = 0.1;          ///< seconds: interpolate between samples at most this far apart
  bool align_sim3 = false;       ///< per snapshot, align the estimate to the truth (Umeyama, scale)
  bool consecutive_only = true;  ///< relative: consecutive graph keyframes only (else every pair)
};

struct FileSamples {
  std::vector<NeesSample> absolute, relative;
  std::vector<std::string> skipped;  ///< why rows were left out (no ground truth, too few points)
};

/// Absolute samples from the keyframe table (not with align_sim3: an alignment fitted to the data
/// is not a gauge held at the truth), relative samples from the relative table (keyframe times
/// from the keyframe table of the same snapshot). run = snapshot, group = "kf<k>" / "<a>-<b>".
/// Consecutive pairs: for each snapshot and `from`, the pair with the smallest `to` (the table
/// holds every consecutive pair of graph keyframes). Hard-fixed keyframes (DoF 0) are no sample.
FileSamples samplesFromTables(const std::vector<KeyframeCovarianceRow>& keyframes,
                              const std::vector<RelativeCovarianceRow>& relative,
                              const GroundTruth& gt, const KeyframeTimes& times,
                              const FileSampleOptions& options);

/// Absolute samples from a pose rawlog: run = rawlog entry (each observation is treated as an
/// independent sample), group = "t<time>".
FileSamples samplesFromRawlog(const std::vector<RawlogPoseRow>& rows, const GroundTruth& gt,
                              const FileSampleOptions& options);

/// One evaluated set: its statistics and, when calibration applies, the statistics after it.
struct ReportSection {
  std::string key;    ///< "absolute", "relative", "heldout_relative", ...
  std::string title;  ///< human-readable
  std::vector<NeesSample> samples;
};

struct Calibration {
  double k = 1;             ///< variance inflation factor
  double weight_scale = 0;  ///< the weight scale of the evaluated covariances
  std::size_t fit_samples = 0;
  std::string fitted_on;  ///< "relative NEES of runs 0..29", ...
  bool fitted = true;     ///< false when k was given (--inflation)
  double calibratedWeightScale() const { return weight_scale / k; }
};

/// Human-readable report: per section ANEES with its region, coverage, Spearman; the calibration
/// and every section again with Σ·k.
void printReport(std::ostream& out, const std::vector<ReportSection>& sections,
                 const std::optional<Calibration>& calibration);
/// The same as JSON (statistics only, not the samples).
std::string reportJson(const std::vector<ReportSection>& sections,
                       const std::optional<Calibration>& calibration);
/// One row per sample: section,run,group,dof,nees,e_0..e_5,sigma_0..sigma_5 (raw covariances).
std::string samplesCsv(const std::vector<ReportSection>& sections);

}  // namespace dbacov::app
