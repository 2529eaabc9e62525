// The extra-constraints file of `dba-posegraph`: loop closures and absolute pose priors.
//
// One constraint per line; '#' starts a comment; blank lines are ignored. Poses are
// tx ty tz qx qy qz qw; covariances are over the conventions §3 tangent [ρ; φ] (right
// perturbation):
//   relative FROM TO  tx ty tz qx qy qz qw  COV     constraint on Z = T_wc_FROM⁻¹ T_wc_TO
//   absolute ID       tx ty tz qx qy qz qw  COV     prior on T_wc of node ID
// where COV is either "sigma_t sigma_r" (isotropic: σ_t² I₃ ⊕ σ_r² I₃) or the 21 upper-triangular
// entries of the 6×6 covariance, row-major.
#pragma once

#include <string>
#include <vector>

#include "dbacov/core/pose_graph.h"

namespace dbacov::app {

struct AbsolutePrior {
  int node = 0;
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
  Matrix6d information = Matrix6d::Identity();
};

struct ExtraConstraints {
  std::vector<PoseGraphEdge> relative;
  std::vector<AbsolutePrior> absolute;
};

/// Parses the file. Throws InputError "FILE:LINE: what was wrong" for unknown keywords, wrong
/// counts, non-numbers, non-finite values, zero quaternions, negative or zero sigmas, covariances
/// that are not positive definite, self-constraints, and node ids not in `nodes` (when given).
ExtraConstraints readExtraConstraints(const std::string& path,
                                      const std::map<int, Eigen::Isometry3d>& nodes);

}  // namespace dbacov::app
