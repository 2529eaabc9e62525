// The second-order term of the depths' noise in the pose covariance (docs/studies/depth-noise.md).
//
// Every pixel's inverse depth is estimated from a few factors, so its error δ_k (variance
// σ_k² = 1/h_k at the poses) does not shrink as the snapshot grows. To second order it enters the
// poses' profile score U twice:
//   δ_k · J'ᵀ W P⊥ ε       J' = ∂[J_i | J_j]/∂d: the pose Jacobians move with the depth
//   ½ δ_k² · Jᵀ W P⊥ r''   r'' = ∂²r/∂d²: the residual is curved in the depth
// (P⊥ removes what the depth itself absorbs). Both are uncorrelated with the first-order score
// Jᵀ W P⊥ ε (odd Gaussian moments), so they add to its variance:
//   M = Σ_k σ_k² J'_kᵀ W P⊥ J'_k = Σ_k [ A_k / h_k − a_k a_kᵀ / h_k² ],
//       A_k = Σ_f J'_fᵀ Λ_f J'_f,  a_k = Σ_f J'_fᵀ Λ_f J_d,f
//   N = Σ_k g_k g_kᵀ / (2 h_k²),  g_k = Σ_f J_fᵀ Λ_f r''_f − b_k (Σ_f J_d,fᵀ Λ_f r''_f) / h_k
// and the Gauss–Newton information evaluated at the estimated depths is itself too large by
// E[S(d̂)] − S(d) ≈ M (the same J' terms, squared; exact when r is linear in d, ∂J_d/∂d = r'' = 0).
// So the information at the true depths is H = S(d̂) − M, the score's variance H + M + N, and
//   Var(ξ̂) ≈ H⁻¹ (H + M + N) H⁻¹ = H⁻¹ + H⁻¹ (M + N) H⁻¹        (≈ S⁻¹ + S⁻¹(2M + N)S⁻¹),
// whose relative size grows with the noise variance (M and N do not change when every weight
// is scaled; S⁻¹ does): negligible where the depths are well determined, the bulk of the
// over-confidence where they are not (white noise at 2×, the low-SNR scene).
//
// Heavy tails. M and N above hold for Gaussian noise, where δ_k and P⊥ε are independent. For
// rows with fourth cumulants they are only uncorrelated. With δ_k = Σ_f α_f ε_f
// (α_f = Λ_f J_d,f / h_k) and the J' term Σ_f β_f ε_f (β_f = Λ_f J'_f − α_f a_k), the variances
// gain the cumulant parts of E[δ² (Σβε)(Σβε)ᵀ] and of ¼ E[δ⁴]:
//   M_κ = Σ_k Σ_{f,g,h,l} cum(ε_f, ε_g, ε_h, ε_l) α_f α_g β_h β_lᵀ,
//   N_κ = Σ_k ¼ (Σ_{f,g,h,l} cum(ε_f, ε_g, ε_h, ε_l) α_f α_g α_h α_l) g_k g_kᵀ,
// over the rows that have a joint fourth cumulant. Two kinds are estimated:
//  - a row with itself, κ_f = γ₂ / Λ_f² (γ₂ the excess kurtosis): M gains γ₂ (J_d,f² / h²) β_f β_fᵀ
//    and N gains γ₂ ¼ Λ_f² J_d,f⁴ / h⁴ g_k g_kᵀ;
//  - the two axes of one factor, cum(x, x, y, y) = γ_xy / (Λ_x Λ_y): a wrong match moves both
//    components of the flow together (for a scale mixture ε = s z, γ_xy = γ₂ / 3). M gains
//    γ_xy [Λ_y J_d,y² β_x β_xᵀ / Λ_x + Λ_x J_d,x² β_y β_yᵀ / Λ_y
//          + 2 J_d,x J_d,y (β_x β_yᵀ + β_y β_xᵀ)] / h²
//    and N gains γ_xy ¼ · 6 Λ_x Λ_y J_d,x² J_d,y² / h⁴ g_k g_kᵀ.
// H = S − M keeps its Gaussian form (E[S(d̂)] needs only Var δ). The cumulants come from the
// standardized residuals z_f = √Λ_f r_f / √(1 − Λ_f J_d,f² / h_k), per edge (so that different
// edge scales are no kurtosis) and pooled: γ₂ = m4 / m2² − 3, γ_xy = E[z_x² z_y²] / m2² − 1 − 2ρ²
// (ρ the axes' correlation). An outlier pixel moves its depth far, and its depth moves the poses'
// Jacobians: this is what the residual energy alone does not see.
#pragma once

#include <Eigen/Core>

#include "dbacov/core/linearization.h"
#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

/// ∂J_j/∂d (2×6) of one pixel factor at the point Y = R_ji p + t_ji d in frame j
/// (transferPoint); ∂J_i/∂d = −∂J_j/∂d · Ad(T_ji). Also r'' = ∂²r/∂d² when asked.
Eigen::Matrix<double, 2, 6> pixelFactorJacobianDepthDerivative(const Eigen::Vector3d& Y,
                                                               const Eigen::Vector3d& t_ji,
                                                               double fx, double fy, double d,
                                                               Eigen::Vector2d* r_dd = nullptr);

struct DepthNoiseTerms {
  Eigen::MatrixXd M;  ///< 6n × 6n (slots of ne.keyframes), symmetric PSD
  Eigen::MatrixXd N;  ///< 6n × 6n, symmetric PSD
  /// E[U] of the curvature term, Σ_k −g_k / (2 h_k): S⁻¹ of it is the O(σ²) bias of the poses.
  Eigen::VectorXd bias_score;
  std::size_t depths = 0;  ///< kept depths summed over
  /// M_κ and N_κ (6n × 6n, symmetric PSD): the fourth-cumulant terms at the estimated γ₂ and
  /// γ_xy (zero when both are 0, or without fourth_cumulants).
  Eigen::MatrixXd M_kurtosis, N_kurtosis;
  /// γ₂: the standardized residuals' excess kurtosis, per edge with at least 8 rows, pooled
  /// weighted by rows; clamped at 0 (lighter tails than Gaussian are not credited).
  double kurtosis = 0;
  /// γ_xy: the two axes' joint fourth cumulant, E[z_x² z_y²] / m2² − 1 − 2ρ² per edge with at least
  /// 8 factors with both axes, pooled weighted by them; clamped to [0, γ₂] (M_κ is PSD only for
  /// γ_xy <= γ₂).
  double cross_kurtosis = 0;
};

/// The terms for the snapshot's weights (weight_scale · w) at its state. `ne` must be the
/// linearization of the same snapshot and options with keep_depth_terms.
/// fourth_cumulants: form M_κ and N_κ (γ₂ and γ_xy are estimated and reported either way).
DepthNoiseTerms depthNoiseTerms(const Snapshot& snapshot, const DbaOptions& options,
                                const DbaNormalEquations& ne, bool fourth_cumulants = true);

}  // namespace dbacov
