// The per-keyframe covariance table written by `dba-covariance --csv` (one row per snapshot and
// graph keyframe) and the number formatting shared by every CSV the apps write.
#pragma once

#include <ostream>
#include <string>

#include "dbacov/core/covariance.h"
#include "dbacov/core/snapshot.h"

namespace dbacov::app {

/// Shortest text that reads back to the same double (%.17g); "inf"/"-inf" for infinities. NaN is
/// a programming error here: it throws std::logic_error rather than reach a file.
std::string formatDouble(double v);

/// The header line, exactly:
/// snapshot,keyframe,tstamp,tx,ty,tz,qx,qy,qz,qw,log10_det,d_opt,a_opt,e_opt,log10_det_rot,
/// log10_det_trans,cov_00,cov_01,...,cov_05,cov_11,...,cov_55 (21 upper-triangular entries).
std::string keyframeCsvHeader();

/// Names of the 21 upper-triangular entries of a 6×6 matrix, "cov_00" ... "cov_55", comma-joined.
std::string upperTriangleNames(const std::string& prefix);
/// The 21 upper-triangular entries of M, row-major, comma-joined.
std::string upperTriangleValues(const Matrix6d& M);

/// Writes one row per graph keyframe of the snapshot.
void writeKeyframeRows(std::ostream& os, const Snapshot& snapshot, const DbaCovariance& cov);

}  // namespace dbacov::app
