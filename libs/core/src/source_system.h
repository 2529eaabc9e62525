// The local normal equations of one source keyframe (a DROID keyframe's pixels, a DPVO frame's
// patches) over the slots its edges touch, and their merge into DbaNormalEquations: what
// linearizeDba and linearizePatchGraph (linearization.h) share.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "dbacov/core/linearization.h"

namespace dbacov::detail {

struct SourceSystem {
  std::vector<int> touched;    ///< slots: touched[0] = the source, then its edges' targets
  Eigen::MatrixXd Hloc, Sloc;  ///< 6T×6T, symmetric
  Eigen::VectorXd g_loc, gS_loc;
  LinearizationStats stats;
  DepthTerms depth;  ///< filled only with keep_depth_terms
};

/// Adds every system's blocks, gradients and counts to `ne` in the order given, so that the
/// result does not depend on the number of threads; with keep_depth_terms moves their depth terms.
void mergeSourceSystems(std::vector<SourceSystem>& systems, bool keep_depth_terms,
                        DbaNormalEquations& ne);

}  // namespace dbacov::detail
