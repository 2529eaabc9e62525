// Checks of dba-posegraph's inputs. See graph_input_checks.h.
#include "graph_input_checks.h"

#include <cmath>
#include <sstream>

#include "dbacov/core/errors.h"
#include "dbacov/core/keyframe_times.h"

namespace dbacov::app::detail {

void checkSymmetricInformation(const Matrix6d& I, const std::string& edge) {
  if (!I.allFinite()) return;  // the positive-definiteness check names it
  const double scale = I.cwiseAbs().maxCoeff();
  for (int r = 0; r < 6; ++r)
    for (int c = r + 1; c < 6; ++c)
      if (!(std::abs(I(r, c) - I(c, r)) <= 1e-9 * scale)) {
        std::ostringstream os;
        os.precision(17);
        os << edge << " has a non-symmetric information matrix (entry (" << r << "," << c
           << ") = " << I(r, c) << ", entry (" << c << "," << r << ") = " << I(c, r)
           << "): expected a symmetric positive definite 6x6 matrix";
        throw InputError(os.str());
      }
}

void checkNodeTimeRow(const std::string& path, int line, int node, double tstamp,
                      std::optional<double> time) {
  const std::string where = path + ":" + std::to_string(line) + ": node " + std::to_string(node);
  if (!std::isfinite(tstamp)) throw InputError(where + ": tstamp is not a finite number");
  if (time && *time == 0)  // what `dba-covariance --graph --fps F` writes for tstamp 0
    throw InputError(where +
                     " has the time 0 s, which MRPT reads as \"no time\" (INVALID_TIMESTAMP): "
                     "expected 0 < t <= 1e10 s since 1970; write the graph with "
                     "dba-covariance --start-time T (T > 0) or give times > 0");
  if (time) checkRepresentableTime(*time, where);
}

}  // namespace dbacov::app::detail
