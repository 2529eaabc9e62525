// The figures of `dba-covariance --plots DIR`, drawn by gnuplot (pngcairo, no X server needed).
//
// Per sequence: every keyframe once, from the snapshot that SequenceHistory chose for it (the last
// processed snapshot where it is not a gauge keyframe; see sequence_history.h). Files:
//   DIR/covariance_covisibility.png  the paper's figure. Left: log10 det Σ of each keyframe's 6×6
//       tangent covariance against the keyframe's time (seconds since the first keyframe when all
//       snapshots carry keyframe times, else DROID's tstamp); gauge keyframes in grey, hard-fixed
//       ones (det Σ = 0) left out and counted in the title. Right: the co-visibility (adjacency)
//       matrix of the graph: a cell (i, j) for every directed edge i → j of any processed
//       snapshot, those of the last snapshot highlighted; i and j are sequence numbers (time
//       order).
//   DIR/pose_sigmas.png  standard deviations over time: translation (ρx, ρy, ρz: camera axes x
//       right, y down, z forward; the snapshots' length unit) and rotation (φx, φy, φz, degrees),
//       log scale; zero (fixed) components left out.
//   DIR/depth_sigma/<snapshot>_<keyframe>.png  per source keyframe with depth maps: its inverse
//       depth d and the standard deviation of d per pixel (conventions §5; log colour scale),
//       colour maps with colour bars; grey where a pixel carries no information. Keyframes whose
//       pixels carry none get no file.
//   DIR/keyframes.csv  the plotted values, one row per keyframe in time order:
//       sequence,tstamp,time_s,snapshot,keyframe,gauge,log10_det,log10_det_trans,log10_det_rot,
//       sigma_tx,sigma_ty,sigma_tz,sigma_rx_deg,sigma_ry_deg,sigma_rz_deg
//       (time_s empty when unknown; log10_det -inf for a hard-fixed keyframe).
// Every file is written atomically; gnuplot's failure leaves the previous files untouched.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "dbacov/app/sequence_history.h"

namespace dbacov::app {

/// The per-pixel maps of one source keyframe (H×W, C order).
struct DepthMaps {
  std::int64_t snapshot = 0;
  int keyframe = 0;
  int H = 0, W = 0;
  std::vector<float> disp;   ///< inverse depth
  std::vector<float> sigma;  ///< standard deviation of the inverse depth; NaN = no information
};

/// Header of DIR/keyframes.csv.
std::string plotKeyframesCsvHeader();

/// Writes the files above into `dir` (created if missing). `depth_maps` is keyed by tstamp.
/// Throws InputError when a file cannot be written or gnuplot fails.
void writeSequencePlots(const SequenceHistory& history,
                        const std::map<double, DepthMaps>& depth_maps, const std::string& dir);

}  // namespace dbacov::app
