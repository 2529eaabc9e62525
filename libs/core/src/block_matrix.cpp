#include "dbacov/core/block_matrix.h"

namespace dbacov {

Matrix6d& BlockSymmetricMatrix::at(int a, int b) {
  auto [it, inserted] = rows_[a].try_emplace(b);
  if (inserted) it->second.setZero();
  return it->second;
}

const Matrix6d* BlockSymmetricMatrix::find(int a, int b) const {
  const auto it = rows_[a].find(b);
  return it == rows_[a].end() ? nullptr : &it->second;
}

void BlockSymmetricMatrix::add(int a, int b, const Matrix6d& M) {
  if (a <= b)
    at(a, b) += M;
  else
    at(b, a) += M.transpose();
}

std::size_t BlockSymmetricMatrix::numBlocks() const {
  std::size_t n = 0;
  for (const Row& r : rows_) n += r.size();
  return n;
}

Eigen::MatrixXd BlockSymmetricMatrix::toDense() const {
  const int n = numSlots();
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  for (int a = 0; a < n; ++a)
    for (const auto& [b, M] : rows_[a]) {
      D.block<6, 6>(6 * a, 6 * b) = M;
      if (a != b) D.block<6, 6>(6 * b, 6 * a) = M.transpose();
    }
  return D;
}

Eigen::SparseMatrix<double> BlockSymmetricMatrix::toSparseUpper() const {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(numBlocks() * 36);
  for (int a = 0; a < numSlots(); ++a)
    for (const auto& [b, M] : rows_[a])
      for (int c = 0; c < 6; ++c)
        for (int r = 0; r < 6; ++r)
          if (a != b || r <= c) trip.emplace_back(6 * a + r, 6 * b + c, M(r, c));
  Eigen::SparseMatrix<double> S(6 * numSlots(), 6 * numSlots());
  S.setFromTriplets(trip.begin(), trip.end());
  return S;
}

}  // namespace dbacov
