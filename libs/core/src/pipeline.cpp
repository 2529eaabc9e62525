#include "dbacov/core/pipeline.h"

#include <stdexcept>

namespace dbacov {

void PipelineOptions::validate() const {
  engine.validate();
  calibration.validate();
  if (converge) converge_solver.validate();
}

namespace {
/// The covariance at the snapshot's state (r.options set).
void covarianceAtState(const Snapshot& s, const PipelineOptions& o, PipelineResult& r) {
  if (o.stated_model) {
    r.cov = std::make_unique<DbaCovariance>(s, r.options, o.solver);
    return;
  }
  r.calibration = selfCalibrate(s, r.options, o.calibration);
  r.cov = std::make_unique<DbaCovariance>(
      selfCalibratedCovariance(s, r.options, o.solver, *r.calibration));
}
}  // namespace

PipelineResult computeCovariance(const Snapshot& s, const PipelineOptions& o) {
  if (o.converge)
    throw std::invalid_argument(
        "PipelineOptions::converge solves the snapshot in place: pass a mutable snapshot");
  o.validate();
  PipelineResult r;
  r.options = o.engine;
  covarianceAtState(s, o, r);
  return r;
}

PipelineResult computeCovariance(Snapshot& s, const PipelineOptions& o) {
  o.validate();
  PipelineResult r;
  r.options = o.engine;
  if (o.converge) {
    if (o.stated_model) {
      r.solve = solveDba(s, o.engine, o.converge_solver);
    } else {
      // At mis-claimed weights of the depth-only factors the solved state is biased: solve at
      // their calibrated variance ratio to the flow (calibrated_solve.h).
      r.reweighted = solveDbaAtCalibratedWeights(s, o.engine, kCalibratedMaxSolves,
                                                 kCalibratedRatioTolerance, o.converge_solver);
      r.solve = r.reweighted->solver;
      r.options = r.reweighted->options;
    }
  }
  covarianceAtState(s, o, r);
  return r;
}

}  // namespace dbacov
