// Reprojection statistics of a snapshot at its stored state: the check that poses, targets and
// conventions fit together (conventions §1: ~0.06 px on the shared DROID snapshot).
#pragma once

#include <vector>

#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

struct WeightedError {
  double error;   ///< |r| in pixels
  double weight;  ///< (w_x + w_y) / 2 of the pixel
};

/// |r| of every pixel factor that carries information under the options' filters.
std::vector<WeightedError> reprojectionErrors(const Snapshot& snapshot, const DbaOptions& options);

/// The weighted median: the smallest error e such that the weights of errors <= e reach half the
/// total weight. Returns 0 for an empty input.
double weightedMedian(std::vector<WeightedError> errors);

}  // namespace dbacov
