// Selected inversion on CHOLMOD's supernodal factor.
//
// With P S Pᵀ = L Lᵀ and Z = (P S Pᵀ)⁻¹ = L⁻ᵀ L⁻¹, take a supernode with columns C (w of them,
// dense diagonal block L_CC) and the rows R below it (L_RC). From Z L = L⁻ᵀ, whose rows R in
// columns C vanish (L⁻ᵀ is upper triangular):
//     Z_RC = −Z_RR · Y,        Y = L_RC L_CC⁻¹
//     Z_CC = L_CC⁻ᵀ L_CC⁻¹ − Z_RCᵀ Y.
// Z_RR is needed only on R × R, which lies inside the pattern of later supernodes (the rows of a
// supernode form a clique of the filled graph), so processing supernodes from last to first
// computes Z on exactly the pattern of L with dense block operations. Entries off the pattern are
// not determined by the recursion; they come from solves.
#include <suitesparse/cholmod.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Cholesky>

#include "dbacov/core/marginal_solver.h"

namespace dbacov {
namespace {

/// RAII for cholmod_common.
class Common {
 public:
  Common() { cholmod_start(&c_); }
  ~Common() { cholmod_finish(&c_); }
  Common(const Common&) = delete;
  Common& operator=(const Common&) = delete;
  cholmod_common* get() { return &c_; }

 private:
  cholmod_common c_;
};

struct FactorDeleter {
  cholmod_common* c;
  void operator()(cholmod_factor* f) const { cholmod_free_factor(&f, c); }
};
struct SparseDeleter {
  cholmod_common* c;
  void operator()(cholmod_sparse* a) const { cholmod_free_sparse(&a, c); }
};
struct DenseDeleter {
  cholmod_common* c;
  void operator()(cholmod_dense* d) const { cholmod_free_dense(&d, c); }
};
using FactorPtr = std::unique_ptr<cholmod_factor, FactorDeleter>;
using SparsePtr = std::unique_ptr<cholmod_sparse, SparseDeleter>;
using DensePtr = std::unique_ptr<cholmod_dense, DenseDeleter>;

int orderingCode(Ordering o) {
  switch (o) {
    case Ordering::Amd:
      return CHOLMOD_AMD;
    case Ordering::Metis:
      return CHOLMOD_METIS;
    case Ordering::Nesdis:
      return CHOLMOD_NESDIS;
    case Ordering::Natural:
      return CHOLMOD_NATURAL;
    case Ordering::Auto:
      break;
  }
  return -1;
}

class CholmodMarginalSolver final : public MarginalSolver {
 public:
  explicit CholmodMarginalSolver(Ordering ordering) : L_(nullptr, FactorDeleter{common_.get()}) {
    cholmod_common* c = common_.get();
    c->supernodal = CHOLMOD_SUPERNODAL;  // the block recursion needs the supernodal layout
    c->final_super = 1;
    c->print = 0;
    c->error_handler = nullptr;
    c->quick_return_if_not_posdef = 1;
    if (ordering != Ordering::Auto) {
      c->nmethods = 1;
      c->method[0].ordering = orderingCode(ordering);
      c->postorder = 1;
    }
  }

  void factorize(const Eigen::SparseMatrix<double>& S_upper) override {
    cholmod_common* c = common_.get();
    n_ = static_cast<int>(S_upper.rows());
    Z_.clear();
    solved_columns_.clear();
    Eigen::SparseMatrix<double> U = S_upper.triangularView<Eigen::Upper>();
    U.makeCompressed();
    diag_ = U.diagonal();
    cholmod_sparse A{};
    A.nrow = A.ncol = n_;
    A.nzmax = U.nonZeros();
    A.p = U.outerIndexPtr();
    A.i = U.innerIndexPtr();
    A.x = U.valuePtr();
    A.stype = 1;  // upper triangle stored
    A.itype = CHOLMOD_INT;
    A.xtype = CHOLMOD_REAL;
    A.dtype = CHOLMOD_DOUBLE;
    A.sorted = 1;
    A.packed = 1;

    L_.reset(cholmod_analyze(&A, c));
    if (!L_)
      throw std::runtime_error("CHOLMOD analyze failed (status " + std::to_string(c->status) + ")");
    cholmod_factorize(&A, L_.get(), c);
    const int* perm = static_cast<const int*>(L_->Perm);
    if (c->status == CHOLMOD_NOT_POSDEF || L_->minor < L_->n) {
      const int col = L_->minor < L_->n ? perm[L_->minor] : -1;
      throw FactorizationError("S is not positive definite", col);
    }
    if (c->status < CHOLMOD_OK || !L_->is_super)
      throw std::runtime_error("CHOLMOD factorize failed (status " + std::to_string(c->status) +
                               ")");

    iperm_.assign(n_, 0);
    for (int k = 0; k < n_; ++k) iperm_[perm[k]] = k;
    indexSupernodes();
    // Relative pivots: L_kk² against the diagonal of the permuted S.
    for (int k = 0; k < n_; ++k) {
      const double l = diagonalOfL(k);
      if (!(l * l > kMinRelativePivot * diag_[perm[k]]))
        throw FactorizationError("S is numerically singular", perm[k]);
    }
  }

  Eigen::MatrixXd covariance(const std::vector<int>& rows, const std::vector<int>& cols) override {
    if (Z_.empty()) selectedInverse();
    Eigen::MatrixXd out(rows.size(), cols.size());
    for (std::size_t b = 0; b < cols.size(); ++b)
      for (std::size_t a = 0; a < rows.size(); ++a) {
        const int i = iperm_[rows[a]], j = iperm_[cols[b]];
        const double* z = findZ(std::max(i, j), std::min(i, j));
        out(a, b) = z ? *z : solvedColumn(cols[b])[rows[a]];
      }
    return out;
  }

  Eigen::VectorXd solve(const Eigen::VectorXd& x) override {
    cholmod_common* c = common_.get();
    cholmod_dense B{};
    B.nrow = n_;
    B.ncol = 1;
    B.nzmax = n_;
    B.d = n_;
    B.x = const_cast<double*>(x.data());
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    DensePtr X(cholmod_solve(CHOLMOD_A, L_.get(), &B, c), DenseDeleter{c});
    if (!X) throw std::runtime_error("CHOLMOD solve failed");
    return Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(X->x), n_);
  }

  std::size_t factorEntries() const override { return L_ ? L_->xsize : 0; }

  std::string name() const override { return "cholmod"; }

 private:
  // Supernode s: columns super[s] .. super[s+1]−1; row indices s_[pi[s] .. pi[s+1]); values
  // column-major nrows × ncols at x[px[s]].
  void indexSupernodes() {
    nsuper_ = static_cast<int>(L_->nsuper);
    super_ = static_cast<const int*>(L_->super);
    pi_ = static_cast<const int*>(L_->pi);
    px_ = static_cast<const int*>(L_->px);
    srow_ = static_cast<const int*>(L_->s);
    Lx_ = static_cast<const double*>(L_->x);
    col2super_.assign(n_, 0);
    for (int s = 0; s < nsuper_; ++s)
      for (int k = super_[s]; k < super_[s + 1]; ++k) col2super_[k] = s;
  }

  double diagonalOfL(int k) const {
    const int s = col2super_[k], nr = pi_[s + 1] - pi_[s], c = k - super_[s];
    return Lx_[px_[s] + c * nr + c];
  }

  /// Z(i, j) for i >= j (permuted numbering), or nullptr when (i, j) is off the pattern of L.
  const double* findZ(int i, int j) const {
    const int s = col2super_[j], nr = pi_[s + 1] - pi_[s];
    const int* first = srow_ + pi_[s];
    const int* it = std::lower_bound(first, first + nr, i);
    if (it == first + nr || *it != i) return nullptr;
    return &Z_[px_[s] + (j - super_[s]) * nr + (it - first)];
  }

  void selectedInverse() {
    Z_.assign(L_->xsize, 0.0);
    std::vector<int> pos(n_, -1);  // scratch: row → position in the current supernode's rows
    for (int s = nsuper_ - 1; s >= 0; --s) {
      const int w = super_[s + 1] - super_[s], nr = pi_[s + 1] - pi_[s], m = nr - w;
      const int* rows = srow_ + pi_[s];
      const Eigen::Map<const Eigen::MatrixXd> Ls(Lx_ + px_[s], nr, w);
      const Eigen::MatrixXd Lcc = Ls.topRows(w);
      Eigen::Map<Eigen::MatrixXd> Zs(Z_.data() + px_[s], nr, w);
      Eigen::MatrixXd Linv = Eigen::MatrixXd::Identity(w, w);
      Lcc.triangularView<Eigen::Lower>().solveInPlace(Linv);
      Eigen::MatrixXd Zcc = Linv.transpose() * Linv;
      // The last supernodes have no rows below their columns (m = 0); Eigen's triangular solve
      // must not see an empty right-hand side (it takes a reference to its first coefficient).
      if (m > 0) {
        // Y = L_RC L_CC⁻¹  (Yᵀ = L_CC⁻ᵀ L_RCᵀ)
        const Eigen::MatrixXd Y = Lcc.triangularView<Eigen::Lower>()
                                      .transpose()
                                      .solve(Ls.bottomRows(m).transpose())
                                      .transpose();
        const Eigen::MatrixXd ZRR = gatherZ(rows + w, m, pos);
        Zs.bottomRows(m).noalias() = -ZRR * Y;
        Zcc.noalias() -= Zs.bottomRows(m).transpose() * Y;
      }
      Zs.topRows(w) = 0.5 * (Zcc + Zcc.transpose());
    }
  }

  /// The dense symmetric Z over the sorted rows r[0..m), all of them in later supernodes.
  Eigen::MatrixXd gatherZ(const int* r, int m, std::vector<int>& pos) const {
    Eigen::MatrixXd out(m, m);
    int b = 0;
    while (b < m) {
      // Columns r[b..] that lie in the same supernode t share one row-position map.
      const int t = col2super_[r[b]], nr = pi_[t + 1] - pi_[t];
      const int* trows = srow_ + pi_[t];
      for (int q = 0; q < nr; ++q) pos[trows[q]] = q;
      for (; b < m && col2super_[r[b]] == t; ++b) {
        const double* zcol = Z_.data() + px_[t] + (r[b] - super_[t]) * nr;
        for (int a = b; a < m; ++a) {
          const int q = pos[r[a]];
          if (q < 0 || trows[q] != r[a])
            throw std::logic_error("selected inverse: row outside the supernode pattern");
          out(a, b) = out(b, a) = zcol[q];
        }
      }
      for (int q = 0; q < nr; ++q) pos[trows[q]] = -1;
    }
    return out;
  }

  const Eigen::VectorXd& solvedColumn(int col) {
    auto it = solved_columns_.find(col);
    if (it != solved_columns_.end()) return it->second;
    Eigen::VectorXd e = Eigen::VectorXd::Zero(n_);
    e[col] = 1.0;
    return solved_columns_.emplace(col, solve(e)).first->second;
  }

  Common common_;
  FactorPtr L_;
  int n_ = 0, nsuper_ = 0;
  const int *super_ = nullptr, *pi_ = nullptr, *px_ = nullptr, *srow_ = nullptr;
  const double* Lx_ = nullptr;
  std::vector<int> col2super_, iperm_;
  Eigen::VectorXd diag_;
  std::vector<double> Z_;
  std::unordered_map<int, Eigen::VectorXd> solved_columns_;
};

}  // namespace

std::unique_ptr<MarginalSolver> makeCholmodMarginalSolver(Ordering ordering) {
  return std::make_unique<CholmodMarginalSolver>(ordering);
}

}  // namespace dbacov
