// Options of the covariance engine: measurement weighting, pixel filters, gauge (conventions §2,
// §4) and the solver (conventions §5). Defaults live in the declarations; validate() names the bad
// field. Text forms (flags, JSON, Python keywords) of every enum come from one table each
// (enum_names.h); DbaOptionOverrides is the one builder from user values (the apps' flags,
// declared once in libs/app/src/engine_cli.h; the scenario; the Python keywords).
#pragma once

#include <optional>
#include <string>

#include "dbacov/core/enum_names.h"

namespace dbacov {

/// How the 7-DoF gauge of monocular DBA (6 pose + scale) is fixed (conventions §4).
struct GaugeOptions {
  enum class Type {
    /// Gaussian prior on the two lowest-indexed keyframes that appear in `ii`, centred on their
    /// estimate, diagonal in the tangent [ρ; φ]. A sigma of 0 hard-fixes those components (the
    /// variables are removed; their covariance is reported as exactly zero).
    TwoPose,
    /// Hard-fix the first such keyframe (6 DoF) and only the distance between the first two
    /// keyframe centres (scale, 1 DoF): the second keyframe keeps 5 free DoF.
    Minimal,
    /// DROID-SLAM's own gauge in that update: hard-fix every graph keyframe below the snapshot's
    /// `t0` = max(1, min(ii) + 1) (DROID's BA optimizes only poses t0..t1−1). Needs the key 't0'.
    Droid,
  };
  Type type = Type::TwoPose;
  double sigma_rot = 0.0;    ///< radians, TwoPose only
  double sigma_trans = 0.0;  ///< snapshot length units, TwoPose only
};

/// Engine presets (conventions §2).
enum class Preset {
  Droid,  ///< DROID-SLAM's own DBA
  Paper,  ///< the paper's code path, corrected
  Dpvo,   ///< DPVO's patch-graph BA (patch graphs only)
};

struct DbaOptions {
  /// Information of a pixel factor is weight_scale · diag(w_x, w_y), in px^-2.
  double weight_scale = kDroidWeightScale;
  /// DROID's rule: drop a pixel factor when Y2 = z_j·d < min_depth_ratio. Unset: no such rule.
  std::optional<double> min_depth_ratio = 0.25;
  /// Keep a pixel factor only if d < 1/near and its metric depth in frame j, Y2/d, is > near.
  std::optional<double> near;
  /// Keep a pixel factor only if d > 1/far.
  std::optional<double> far;
  /// Patch graphs only (DPVO's BA): drop an edge whose residual norm |r| is >= max_residual px.
  std::optional<double> max_residual;
  /// Patch graphs only (DPVO's BA): drop an edge whose projection π(Y) lies outside
  /// (−m, 2·cx + m) × (−m, 2·cy + m) for m = image_margin px.
  std::optional<double> image_margin;
  /// Depth variables with Hdd <= depth_info_eps are unobservable; they are not eliminated and
  /// their factors contribute only through the pose block (b_k is then negligible, see
  /// linearization.cpp).
  double depth_info_eps = 1e-12;
  /// RGB-D (snapshot key 'disps_sens'): information α of the depth-sensor factor
  /// α·(d − d_sens)² on every source pixel with d_sens > 0, in (inverse depth)^-2. DROID's BA
  /// (droid_kernels.cu) uses α = 0.05 with its 0.001-weighted reprojection factors; 0 = off.
  double sensor_depth_weight = 0.05;
  GaugeOptions gauge;

  /// DROID's DBA weight scale (droid_kernels.cu): the `droid` preset's, and the scale that
  /// dba-evaluate assumes for files when none is given.
  static constexpr double kDroidWeightScale = 1e-3;

  /// DROID-SLAM's own DBA: weight_scale 0.001, Y2 >= 0.25, two-pose gauge hard-fixed.
  static DbaOptions droid();
  /// The paper's code path, corrected: weight_scale 0.1, near 0.25 / far 2 depth filter, two-pose
  /// gauge with sigmas 1° (rotation) and 0.05 (translation).
  static DbaOptions paper();
  /// DPVO's patch-graph BA: weight_scale 1, Y2 >= 0.2, max_residual 128 px, image_margin 64 px,
  /// gauge droid (the frames below t0 are held).
  static DbaOptions dpvo();
  static DbaOptions preset(Preset preset);
  /// "droid", "paper" or "dpvo"; throws std::invalid_argument for anything else.
  static DbaOptions preset(const std::string& name);

  /// Throws std::invalid_argument when a value is out of its domain (non-positive weight scale,
  /// negative sigmas, near >= far, ...).
  void validate() const;
};

enum class SolverKind {
  Sparse,  ///< CHOLMOD + sparse-inverse recursion (default)
  Dense,   ///< dense Cholesky + full inverse (the test reference; small graphs only)
};

/// Fill-reducing orderings of the sparse solver. Results do not depend on the ordering (up to
/// round-off); speed and memory do.
enum class Ordering {
  Auto,     ///< CHOLMOD's default: AMD, and METIS when AMD's fill is poor
  Amd,      ///< approximate minimum degree
  Metis,    ///< METIS nested dissection
  Nesdis,   ///< CHOLMOD's nested dissection
  Natural,  ///< no permutation (tests)
};

/// The one builder of DbaOptions from what a user gave (flags, JSON, Python keywords): the preset,
/// then every value that is set. `gauge` names the gauge type only: a two-pose gauge keeps the
/// preset's (or the given) sigmas, the minimal and droid gauges have none (giving a sigma with
/// them is an error).
struct DbaOptionOverrides {
  Preset preset = Preset::Droid;
  std::optional<double> weight_scale;
  std::optional<GaugeOptions::Type> gauge;
  std::optional<double> gauge_sigma_rot, gauge_sigma_trans;
  std::optional<double> near, far;
  std::optional<double> min_depth_ratio;      ///< 0 turns DROID's depth-ratio rule off
  std::optional<double> sensor_depth_weight;  ///< RGB-D: the depth-sensor factor's α

  /// The options; throws std::invalid_argument for values out of their domain (DbaOptions::
  /// validate's messages) or contradicting ones.
  DbaOptions resolve() const;
};

/// How DbaCovariance computes (conventions §5).
struct CovarianceOptions {
  SolverKind kind = SolverKind::Sparse;
  Ordering ordering = Ordering::Auto;
  /// Keep the depth terms of the linearization so that inverseDepthSigma() can answer (costs
  /// 6·(1 + targets) doubles per pixel of every source keyframe).
  bool depth_variances = false;
};

template <>
struct EnumNames<GaugeOptions::Type> {
  static constexpr const char* what = "gauge";
  static constexpr std::array<std::pair<GaugeOptions::Type, const char*>, 3> entries{
      {{GaugeOptions::Type::TwoPose, "two-pose"},
       {GaugeOptions::Type::Minimal, "minimal"},
       {GaugeOptions::Type::Droid, "droid"}}};
};
template <>
struct EnumNames<Preset> {
  static constexpr const char* what = "preset";
  static constexpr std::array<std::pair<Preset, const char*>, 3> entries{
      {{Preset::Droid, "droid"}, {Preset::Paper, "paper"}, {Preset::Dpvo, "dpvo"}}};
};
template <>
struct EnumNames<SolverKind> {
  static constexpr const char* what = "solver";
  static constexpr std::array<std::pair<SolverKind, const char*>, 2> entries{
      {{SolverKind::Sparse, "sparse"}, {SolverKind::Dense, "dense"}}};
};
template <>
struct EnumNames<Ordering> {
  static constexpr const char* what = "ordering";
  static constexpr std::array<std::pair<Ordering, const char*>, 5> entries{
      {{Ordering::Auto, "auto"},
       {Ordering::Amd, "amd"},
       {Ordering::Metis, "metis"},
       {Ordering::Nesdis, "nesdis"},
       {Ordering::Natural, "natural"}}};
};

}  // namespace dbacov
