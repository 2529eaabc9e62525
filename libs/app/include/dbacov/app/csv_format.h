// Number and matrix formatting shared by every table the apps write.
#pragma once

#include <string>

#include "dbacov/core/se3.h"

namespace dbacov::app {

/// Shortest text that reads back to the same double (%.17g); "inf"/"-inf" for infinities, "0" for
/// −0. NaN is a programming error here: it throws std::logic_error rather than reach a file.
std::string formatDouble(double v);

/// Names of the 21 upper-triangular entries of a 6×6 matrix, row-major, comma-joined:
/// prefix00,prefix01,...,prefix05,prefix11,...,prefix55.
std::string upperTriangleNames(const std::string& prefix);
/// The 21 upper-triangular entries of M, row-major, comma-joined.
std::string upperTriangleValues(const Matrix6d& M);

/// tx,ty,tz,qx,qy,qz,qw of T (qw >= 0), comma-joined.
std::string poseValues(const Eigen::Isometry3d& T);

}  // namespace dbacov::app
