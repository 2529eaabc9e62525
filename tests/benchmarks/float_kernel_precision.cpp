// The optional single-precision pixel kernel, decided by its precision before its speed:
// how far do the keyframe covariances move when every pixel factor is linearized and reduced in
// float, and only the sums over pixels are kept in double?
//
// This program does not build a float kernel. It emulates what one would compute, pixel by pixel,
// in plain scalar code templated on the per-pixel type, and hands the resulting reduced system to
// the engine's own gauge and marginal solver (a given linearization, given_model.h):
//   double: the same arithmetic in double (checked against linearizeDba's S: the emulation is
//           the engine's model, not another one);
//   float J: the pixel's Jacobians computed in float from float inputs, products and the depth
//           elimination in double;
//   float:  Jacobians, the pixel's products λ u uᵀ, its depth column b and h, and its Schur term
//           b bᵀ / h all in float, accumulated over pixels in double (what "a float kernel with
//           double accumulation of the normal equations" computes per pixel).
// It prints, per snapshot, the largest change of a keyframe marginal relative to that marginal's
// largest diagonal entry, and the largest relative change of a marginal σ. The project accepts the
// float kernel only within 1e-6 relative of the double path.
//
//   float_kernel_precision [SNAPSHOT.npz ...]   (default: the shared snapshot and a simulated
//                                                DROID-sized window)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "bench_problems.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/dba_factor.h"
#include "dbacov/core/given_model.h"
#include "dbacov/core/linearization.h"

namespace {

using namespace dbacov;

enum class Precision { Double, FloatJacobians, FloatProducts, Float, FloatReducedRows };

/// The reduced system S of linearization.h, pixel by pixel: Jacobians in JScalar, the products
/// λ u uᵀ in Scalar, the depth column b, h and the Schur term b bᵀ / h in DScalar, every sum over
/// pixels in double.
/// With kReducedRows, the pixel's depth-reduced rows are formed first and their products summed
/// (all in DScalar).
template <typename JScalar, typename Scalar, typename DScalar, bool kReducedRows = false>
BlockSymmetricMatrix reducedSystem(const Snapshot& s, const DbaOptions& o,
                                   const std::vector<int>& slot_of) {
  using Vec3 = Eigen::Matrix<JScalar, 3, 1>;
  using Mat3 = Eigen::Matrix<JScalar, 3, 3>;
  const int n =
      static_cast<int>(std::count_if(slot_of.begin(), slot_of.end(), [](int a) { return a >= 0; }));
  BlockSymmetricMatrix S(n);
  const int HW = static_cast<int>(s.pixelsPerFrame());
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const JScalar fx = static_cast<JScalar>(K.fx), fy = static_cast<JScalar>(K.fy),
                cx = static_cast<JScalar>(K.cx), cy = static_cast<JScalar>(K.cy);
  std::vector<int> sources(s.ii.begin(), s.ii.end());
  std::sort(sources.begin(), sources.end());
  sources.erase(std::unique(sources.begin(), sources.end()), sources.end());
  for (int src : sources) {
    std::vector<int> edges, touched{slot_of[src]}, tpos;
    for (int e = 0; e < s.numEdges(); ++e) {
      if (s.ii[e] != src) continue;
      if (s.jj[e] == src) throw std::runtime_error("stereo edges are not emulated");
      const int slot = slot_of[s.jj[e]];
      auto it = std::find(touched.begin(), touched.end(), slot);
      tpos.push_back(static_cast<int>(it - touched.begin()));
      if (it == touched.end()) touched.push_back(slot);
      edges.push_back(e);
    }
    const int T = static_cast<int>(touched.size());
    std::vector<Mat3> R(edges.size());
    std::vector<Vec3> t(edges.size());
    // The same relative poses as the engine, then rounded (a float kernel gets them this way).
    std::vector<Eigen::Matrix3d> Rd(edges.size());
    std::vector<Eigen::Vector3d> td(edges.size());
    for (std::size_t q = 0; q < edges.size(); ++q) {
      const Eigen::Isometry3d T_ji = s.T_cw(static_cast<int>(s.jj[edges[q]])) * s.T_wc(src);
      Rd[q] = T_ji.linear();
      td[q] = T_ji.translation();
      R[q] = Rd[q].cast<JScalar>();
      t[q] = td[q].cast<JScalar>();
    }
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(6 * T, 6 * T);
    Eigen::Matrix<DScalar, Eigen::Dynamic, 1> b(6 * T);
    Eigen::Matrix<DScalar, Eigen::Dynamic, Eigen::Dynamic> P(6 * T, 6 * T);
    struct PixelRow {
      Eigen::Matrix<Scalar, 12, 1> u;  // [J_i | J_j] of the row
      double lam, jd;
      int o2;  // the target's offset in the source's 6T coordinates
    };
    std::vector<PixelRow> rows;
    for (int p = 0; p < HW; ++p) {
      const double d = s.disps[static_cast<std::size_t>(src) * HW + p];
      if (!(d > 0)) continue;
      b.setZero();
      DScalar h = 0;
      rows.clear();
      for (std::size_t q = 0; q < edges.size(); ++q) {
        const int e = edges[q];
        const double lam[2] = {o.weight_scale * s.weightPlane(e, 0)[p],
                               o.weight_scale * s.weightPlane(e, 1)[p]};
        if (!(lam[0] > 0 || lam[1] > 0)) continue;
        // The engine's filter decides in double, as the float kernel's would on its own values;
        // any pixel it keeps differently would show as a difference below.
        const Eigen::Vector3d Yd = transferPoint(Rd[q], td[q], K, p % s.W, p / s.W, d);
        if (!keepPixelFactor(o, d, Yd.z())) continue;
        // linearizePixelFactor's formulas (dba_factor.h) in JScalar.
        const JScalar x = static_cast<JScalar>(p % s.W), y = static_cast<JScalar>(p / s.W),
                      dj = static_cast<JScalar>(d);
        const Vec3 pr((x - cx) / fx, (y - cy) / fy, JScalar(1));
        const Vec3 Y = R[q] * pr + t[q] * dj;
        const JScalar iz = JScalar(1) / Y.z();
        Eigen::Matrix<JScalar, 2, 3> mdPi;
        mdPi << -fx * iz, JScalar(0), fx * Y.x() * iz * iz, JScalar(0), -fy * iz,
            fy * Y.y() * iz * iz;
        Mat3 hp, hY;
        hp << 0, -pr.z(), pr.y(), pr.z(), 0, -pr.x(), -pr.y(), pr.x(), 0;
        hY << 0, -Y.z(), Y.y(), Y.z(), 0, -Y.x(), -Y.y(), Y.x(), 0;
        const Eigen::Matrix<JScalar, 2, 3> mdPiR = mdPi * R[q];
        Eigen::Matrix<JScalar, 2, 6> Ji, Jj;
        Ji.template leftCols<3>() = dj * mdPiR;
        Ji.template rightCols<3>() = -mdPiR * hp;
        Jj.template leftCols<3>() = -dj * mdPi;
        Jj.template rightCols<3>() = mdPi * hY;
        const Eigen::Matrix<JScalar, 2, 1> Jd = mdPi * t[q];
        for (int c = 0; c < 2; ++c) {
          if (!(lam[c] > 0)) continue;
          PixelRow r;
          r.u << Ji.row(c).transpose().template cast<Scalar>(),
              Jj.row(c).transpose().template cast<Scalar>();
          r.lam = lam[c];
          r.jd = Jd[c];
          r.o2 = 6 * tpos[q];
          rows.push_back(r);
          const DScalar ld = static_cast<DScalar>(lam[c]), jdd = static_cast<DScalar>(Jd[c]);
          const Eigen::Matrix<DScalar, 12, 1> ud = r.u.template cast<DScalar>();
          b.template segment<6>(0) += (ld * jdd) * ud.template head<6>();
          b.template segment<6>(r.o2) += (ld * jdd) * ud.template tail<6>();
          h += ld * jdd * jdd;
        }
      }
      if (rows.empty()) continue;
      const bool reduce = static_cast<double>(h) > o.depth_info_eps;
      if (kReducedRows && reduce) {
        // Σ_k v_k v_kᵀ with v_k = √λ u_k − (√λ J_d / h) b, the pixel's depth-reduced rows: equal
        // to Σ λ u uᵀ − b bᵀ / h, without the difference of two large products.
        for (const PixelRow& r : rows) {
          const DScalar sl = static_cast<DScalar>(std::sqrt(r.lam));
          Eigen::Matrix<DScalar, Eigen::Dynamic, 1> v = -(sl * static_cast<DScalar>(r.jd) / h) * b;
          v.template segment<6>(0) += sl * r.u.template head<6>().template cast<DScalar>();
          v.template segment<6>(r.o2) += sl * r.u.template tail<6>().template cast<DScalar>();
          P.noalias() = v * v.transpose();
          A += P.template cast<double>();
        }
        continue;
      }
      for (const PixelRow& r : rows) {
        const Scalar l = static_cast<Scalar>(r.lam);
        const Eigen::Matrix<Scalar, 12, 12> uu = (l * r.u) * r.u.transpose();
        A.block<6, 6>(0, 0) += uu.template block<6, 6>(0, 0).template cast<double>();
        A.block<6, 6>(r.o2, r.o2) += uu.template block<6, 6>(6, 6).template cast<double>();
        A.block<6, 6>(0, r.o2) += uu.template block<6, 6>(0, 6).template cast<double>();
        A.block<6, 6>(r.o2, 0) += uu.template block<6, 6>(6, 0).template cast<double>();
      }
      if (!reduce) continue;
      P.noalias() = (b / h) * b.transpose();
      A -= P.template cast<double>();
    }
    for (int a = 0; a < T; ++a)
      for (int c = 0; c < T; ++c)
        if (a == c || touched[a] < touched[c])
          S.add(touched[a], touched[c], A.block<6, 6>(6 * a, 6 * c));
  }
  return S;
}

struct Result {
  double marginal = 0, sigma = 0;  // largest relative change (see the file comment)
};

Result compare(const DbaCovariance& ref, const DbaCovariance& other) {
  Result r;
  for (int k : ref.keyframes()) {
    const Matrix6d a = ref.marginal(k), b = other.marginal(k);
    const double scale = a.diagonal().maxCoeff();
    if (!(scale > 0)) continue;  // gauge-fixed
    r.marginal = std::max(r.marginal, (a - b).cwiseAbs().maxCoeff() / scale);
    for (int i = 0; i < 6; ++i)
      if (a(i, i) > 0) r.sigma = std::max(r.sigma, std::abs(std::sqrt(b(i, i) / a(i, i)) - 1.0));
  }
  return r;
}

/// Returns false when the double emulation is not the engine's model (its marginals differ by
/// more than rounding), so that the smoke test fails instead of printing numbers about another
/// model.
bool run(const std::string& name, const Snapshot& s) {
  const DbaOptions o;
  const DbaNormalEquations ne = linearizeDba(s, o);
  const DbaCovariance engine(s, o);
  std::printf("%s: %d keyframes, %d edges, %zu pixel factors\n", name.c_str(), s.numKeyframes(),
              s.numEdges(), static_cast<std::size_t>(ne.stats.factors_used));
  const Precision kinds[] = {Precision::Double, Precision::FloatJacobians, Precision::FloatProducts,
                             Precision::Float, Precision::FloatReducedRows};
  for (Precision kind : kinds) {
    auto emulated = std::make_shared<DbaNormalEquations>(ne);
    switch (kind) {
      case Precision::Double:
        emulated->S = reducedSystem<double, double, double>(s, o, ne.slot_of);
        break;
      case Precision::FloatJacobians:
        emulated->S = reducedSystem<float, double, double>(s, o, ne.slot_of);
        break;
      case Precision::FloatProducts:
        emulated->S = reducedSystem<float, float, double>(s, o, ne.slot_of);
        break;
      case Precision::Float:
        emulated->S = reducedSystem<float, float, float>(s, o, ne.slot_of);
        break;
      case Precision::FloatReducedRows:
        emulated->S = reducedSystem<float, float, float, true>(s, o, ne.slot_of);
        break;
    }
    // How close the emulated S is to the engine's, relative to S's largest entry.
    const Eigen::MatrixXd Se = ne.S.toDense(), Sm = emulated->S.toDense();
    const double dS = (Se - Sm).cwiseAbs().maxCoeff() / Se.cwiseAbs().maxCoeff();
    detail::GivenModel given;
    given.linearization = emulated;
    const DbaCovariance cov = given.build(s, o, {});
    const Result r = compare(engine, cov);
    const char* label = kind == Precision::Double           ? "double (the check)"
                        : kind == Precision::FloatJacobians ? "float J"
                        : kind == Precision::FloatProducts  ? "float J, lam u u'"
                        : kind == Precision::Float          ? "float J, products, Schur"
                                                            : "float reduced rows";
    std::printf("  %-26s max|dS|/max|S| %.2e   marginals %.2e   sigma %.2e\n", label, dS,
                r.marginal, r.sigma);
    if (kind == Precision::Double && !(r.marginal < 1e-9 && dS < 1e-12)) {
      std::fprintf(stderr,
                   "float_kernel_precision: %s: the double emulation differs from the engine "
                   "(marginals %.2e, S %.2e): it no longer computes linearizeDba's model\n",
                   name.c_str(), r.marginal, dS);
      return false;
    }
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::vector<std::string> files(argv + 1, argv + argc);
    bool ok = true;
    if (files.empty()) {
      ok = run("simulated DROID-sized window",
               sim::generateSyntheticSnapshot(bench::droidSizedWindowConfig()).snapshot);
      if (std::filesystem::exists(bench::kSharedSnapshot)) files.push_back(bench::kSharedSnapshot);
    }
    for (const std::string& f : files) ok = run(f, io::loadSnapshotNpz(f, 0)) && ok;
    if (!ok) return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "float_kernel_precision: %s\n", e.what());
    return 1;
  }
  return 0;
}
