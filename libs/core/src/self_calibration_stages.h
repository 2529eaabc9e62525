// The self-calibration's stages (self_calibration.h), shared by its source files: the dense model
// of one state (self_calibration_model.cpp), the pass over every edge's residuals
// (edge_pass.cpp), the nuisance model's fit and covariance (nuisance_fit.cpp). Private to
// libs/core/src.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "dbacov/core/gauge.h"
#include "dbacov/core/linearization.h"
#include "dbacov/core/nuisance_basis.h"
#include "dbacov/core/self_calibration.h"

namespace dbacov::selfcal {

using Vector12d = Eigen::Matrix<double, 12, 1>;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The white scales are held within this factor of the pooled scale Σ q / Σ ρ (either side); a
/// non-finite value (no information to estimate it from) becomes the upper bound.
inline constexpr double kScaleRange = 1e9;
double clampScale(double x, double lo, double hi);

/// The options with the sensor readings' information α divided by their variance factor.
DbaOptions sensorCalibratedOptions(const DbaOptions& o, double sensor_scale);

/// The linearization, gauge and dense pose covariance of one state and weighting.
struct DenseModel {
  DbaNormalEquations ne;
  GaugeParameterization gauge;
  Eigen::MatrixXd basis;    ///< 6n × K, block diagonal
  Eigen::MatrixXd Sr;       ///< K × K reduced information
  Eigen::MatrixXd L_r;      ///< K × K, lower Cholesky factor of Sr (Sr = L Lᵀ)
  Eigen::MatrixXd Sigma_r;  ///< K × K
  Eigen::MatrixXd Sigma;    ///< 6n × 6n, full tangent
};
/// Throws NumericalError naming the keyframe where the reduced information is not positive
/// definite (no source prefix: the callers name the snapshot).
DenseModel buildModel(const Snapshot& s, const DbaOptions& o, bool keep_depth_terms = false);

/// How far the model's state is from the optimum of its factors (self_calibration.h).
OptimumDistance optimumDistance(const DenseModel& m);

/// Per-edge sums of one pass (self_calibration.h's notation).
struct EdgeAccum {
  std::size_t pixels = 0, rows = 0;
  double sum_r2 = 0;  ///< Σ r², px²
  double q = 0;       ///< Σ λ r²
  double lev = 0;     ///< Σ leverage
  double tr_SI = 0;   ///< tr(Σ I_e)
  /// A factor on the depths alone (a stereo edge, a source's sensor readings): its rows have no
  /// pose Jacobian, v = −(J_d / h) B_p; of the nuisance fields below only source, w and
  /// pixel_of are set.
  bool depth_only = false;
  Eigen::VectorXd g;  ///< 6n, depth-reduced score
  // The nuisance sums, on the edge's source slots (slots[a] = the a-th 6-block's keyframe slot):
  std::vector<int> slots;
  // The factors of I_e, the edge's 6T × 6T share of S (not formed), I = P(Auu)Pᵀ − (P X +
  // transpose) + B diag(w) Bᵀ over the source's depth columns B (SourceTerms), P scattering the
  // edge's 12 coordinates idx into the 6T and X = Σ_p acr_p B_pᵀ (12 × 6T: small, where the acr_p
  // themselves would be 12 per pixel and edge, 17 MB on the shared snapshot).
  int source = -1;            ///< index into the pass's SourceTerms
  std::array<int, 12> idx{};  ///< the edge's 12 coordinates within the source's 6T
  Matrix12d Auu;              ///< Σ u uᵀ
  Eigen::Matrix<double, 12, Eigen::Dynamic> cross;  ///< 12 × 6T, Σ_p (Σ_k c_k u_k) B_pᵀ
  Eigen::VectorXd w;                                ///< P, Σ_k c_k² per pixel
  std::vector<int> pixel_of;                        ///< P, the pixels
  Eigen::MatrixXd C;                                ///< 6T × m, Σ_{rows of e} v φᵀ
  Eigen::MatrixXd Mn;  ///< m × m, the field's information after poses and depths
  /// Per field group g, m × m: (M_s D_g M_s)_ee, Cov(t) per unit σ_g² (the source's fields).
  std::vector<Eigen::MatrixXd> An;
  std::vector<int> group;    ///< the group of each of the m coordinates
  Eigen::VectorXd t;         ///< m, the field's depth-reduced score Φ̃ᵀ Λ r
  Eigen::VectorXd CSC_diag;  ///< diag(Cᵀ Σ C)
};

/// What the edges leaving one source keyframe share, so that Σ_e f_e I_e is one product per
/// source once the white scales f_e + 1 are known (instead of one I_e per edge).
struct SourceTerms {
  std::vector<int> touched;  ///< the source's slots (its 6-blocks)
  RowMatrix B;               ///< 6T × HW, every pixel's depth column (rows along pixels)
};

/// One pass over every edge at the snapshot's state and weights, with the model's Σ: one
/// EdgeAccum per edge and, in `sensor`, one per source keyframe in the pass's source order for
/// its sensor readings (RGB-D; rows = 0 without). With `nuisance` the field's sums too, and each
/// source's SourceTerms in `source_terms`; without, only the white-noise sums (q, lev, tr_SI, g).
std::vector<EdgeAccum> edgePass(const Snapshot& s, const DbaOptions& o, const DenseModel& m,
                                const NuisanceBasis* nuisance,
                                std::vector<SourceTerms>* source_terms,
                                std::vector<EdgeAccum>* sensor);

/// Σ q, Σ (rows − lev) and Σ rows over accumulators: a pooled scale's numerator and denominator.
struct Pooled {
  double q = 0, redundancy = 0, rows = 0;
};
Pooled pooled(const std::vector<EdgeAccum>& accs);

/// The nuisance model's estimates (σ² of the field groups, every edge's s_e clamped to [lo, hi])
/// written into `out`, and its covariance in the gauge's reduced coordinates (returned).
Eigen::MatrixXd nuisanceCovariance(const DenseModel& m, const std::vector<EdgeAccum>& acc,
                                   const std::vector<SourceTerms>& sources,
                                   const std::vector<EdgeAccum>& sensor, double sensor_scale,
                                   int groups, double lo, double hi, SelfCalibration* out);

}  // namespace dbacov::selfcal
