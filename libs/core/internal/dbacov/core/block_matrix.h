// A symmetric matrix of 6×6 blocks over pose slots, stored as its upper block triangle.
#pragma once

#include <map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "dbacov/core/se3.h"

namespace dbacov {

class BlockSymmetricMatrix {
 public:
  using Row = std::map<int, Matrix6d>;  ///< column b (>= row) → block (row, b)

  explicit BlockSymmetricMatrix(int num_slots = 0) : rows_(num_slots) {}

  int numSlots() const { return static_cast<int>(rows_.size()); }

  /// Block (a, b), created as zero when absent. Precondition: a <= b.
  Matrix6d& at(int a, int b);
  /// Block (a, b) or nullptr. Precondition: a <= b.
  const Matrix6d* find(int a, int b) const;
  /// Adds M to block (a, b) for any order of a, b (M is transposed when a > b). For a == b, M is
  /// added as given (the caller passes a symmetric block).
  void add(int a, int b, const Matrix6d& M);

  const Row& row(int a) const { return rows_[a]; }
  /// Number of stored blocks (diagonal included).
  std::size_t numBlocks() const;

  /// The full symmetric 6n×6n matrix (tests and dense references).
  Eigen::MatrixXd toDense() const;
  /// The upper triangle as a column-major sparse 6n×6n matrix (the solvers' input).
  Eigen::SparseMatrix<double> toSparseUpper() const;

 private:
  std::vector<Row> rows_;
};

}  // namespace dbacov
