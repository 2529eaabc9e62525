// Private to dbacov_app: checks of dba-posegraph's inputs that its loaders do not make.
#pragma once

#include <optional>
#include <string>

#include "dbacov/core/se3.h"

namespace dbacov::app::detail {

/// InputError "<edge> has a non-symmetric information matrix (entry (r,c) = x, (c,r) = y) ..."
/// when an entry differs from its mirror by more than 1e-9 of the largest entry (a .graphbin can
/// hold any 6×6 matrix; MRPT and dbacov use only one triangle).
void checkSymmetricInformation(const Matrix6d& I, const std::string& edge);

/// One row of PREFIX.nodes.csv: the tstamp must be finite, the time (when given) a time that the
/// outputs can represent (keyframe_times.h). InputError "<path>:<line>: node <id>: ...".
void checkNodeTimeRow(const std::string& path, int line, int node, double tstamp,
                      std::optional<double> time);

}  // namespace dbacov::app::detail
