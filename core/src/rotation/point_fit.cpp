#include "core/src/pow2.hpp"

#include <mlsdeform/point_fit.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mlsdeform {

namespace {

template <class T>
using Weights = Eigen::Ref<const Eigen::Matrix<T, Eigen::Dynamic, 1>>;

/// p scaled by 2^-e (exact: a power of two), e the exponent of its largest coordinate (pow2.hpp).
template <class T>
Points<T> to_unit(const Eigen::Ref<const Points<T>>& p, int e) {
  Points<T> r(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int c = 0; c < 3; ++c) r(i, c) = std::ldexp(p(i, c), -e);
  return r;
}

// Weighted centroids (eq. 2), H = sum w qhat phat^T (eq. 6, column convention) and sum w |phat|^2, with p and q
// each scaled by a power of two to their largest coordinate (2^ep, 2^eq): the products cannot overflow or
// underflow at any scale (H in the caller's units is of order |q| |p|: beyond double at 1e200), the rotation is
// unchanged (H matters up to a positive factor), and scale and translation are brought back exactly:
// s = s' 2^(eq - ep), t = (q*' - s' R p*') 2^eq (rigid: t = (q*' 2^(eq - g) - R p*' 2^(ep - g)) 2^g with
// g = max(ep, eq)). Scaling p and q by one power of two thus leaves R and s unchanged and scales t bitwise
// (rounded once more only where t lands in T's subnormal range); in the normal range every scaling is exact
// and the result is that of the same formulas in the caller's units.
template <class T>
SimilarityTransform<T> fit(const Eigen::Ref<const Points<T>>& p_in, const Eigen::Ref<const Points<T>>& q_in,
                           const Weights<T>& w, RotationMethod method, bool with_scale, const char* name) {
  const std::string fn(name);
  const Eigen::Index n = p_in.rows();
  if (n == 0) throw std::invalid_argument(fn + ": no points");
  if (q_in.rows() != n)
    throw std::invalid_argument(fn + ": p has " + std::to_string(n) + " points but q has " +
                                std::to_string(q_in.rows()));
  if (w.size() != 0 && w.size() != n)
    throw std::invalid_argument(fn + ": " + std::to_string(n) + " points but " + std::to_string(w.size()) + " weights");
  if (!p_in.allFinite()) throw std::invalid_argument(fn + ": non-finite coordinate in p");
  if (!q_in.allFinite()) throw std::invalid_argument(fn + ": non-finite coordinate in q");
  if (!w.allFinite()) throw std::invalid_argument(fn + ": non-finite weight");
  if (w.size() != 0 && (w.array() < T(0)).any()) throw std::invalid_argument(fn + ": negative weight");
  Eigen::Matrix<T, Eigen::Dynamic, 1> wn =
      w.size() ? Eigen::Matrix<T, Eigen::Dynamic, 1>(w) : Eigen::Matrix<T, Eigen::Dynamic, 1>::Ones(n);
  const T wmax = wn.maxCoeff();
  if (!(wmax > T(0))) throw std::invalid_argument(fn + ": the weights sum to zero");
  wn /= wmax;      // first by the largest, so that the sum cannot overflow (weights near the float maximum)
  wn /= wn.sum();  // normalised weights: the fit is invariant under their scale
  const int ep = detail::exponent_of(p_in.cwiseAbs().maxCoeff());
  const int eq = detail::exponent_of(q_in.cwiseAbs().maxCoeff());
  const Points<T> p = to_unit<T>(p_in, ep), q = to_unit<T>(q_in, eq);
  const Vector3<T> p_star = p.transpose() * wn, q_star = q.transpose() * wn;
  const Points<T> phat = p.rowwise() - p_star.transpose();
  const Points<T> qhat = q.rowwise() - q_star.transpose();
  const Matrix3<T> H = qhat.transpose() * wn.asDiagonal() * phat;
  SimilarityTransform<T> t;
  t.rotation = fit_rotation<T>(H, method);
  const Vector3<T> Rp = t.rotation * p_star;
  const char* type = sizeof(T) == 4 ? "float" : "double";
  // Sec. 6.1: mu_s = y / sum w |phat|^2 with y = trace(R^T H), the optimal value; 1 where all p coincide.
  const T spread = with_scale ? (phat.array().square().rowwise().sum().matrix().transpose() * wn)(0) : T(0);
  Vector3<T> tu;  // the translation in units of 2^et
  int et = eq;
  if (spread > T(0)) {
    const T s = (t.rotation.transpose() * H).trace() / spread;
    t.scale = std::ldexp(s, eq - ep);
    if (!std::isfinite(t.scale))
      throw std::invalid_argument(fn + ": the scale overflows " + type + " (q is about 2^" + std::to_string(eq - ep) +
                                  " times larger than p)");
    tu = q_star - s * Rp;  // (q* - s R p*) / 2^eq
  } else {
    et = std::max(ep, eq);
    for (int c = 0; c < 3; ++c) tu[c] = std::ldexp(q_star[c], eq - et) - std::ldexp(Rp[c], ep - et);
  }
  for (int c = 0; c < 3; ++c) t.translation[c] = std::ldexp(tu[c], et);
  if (!t.translation.allFinite()) throw std::invalid_argument(fn + ": the translation q* - s R p* overflows " + type);
  return t;
}

}  // namespace

template <class T>
SimilarityTransform<T> fit_rigid(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                                 const Weights<T>& w, RotationMethod method) {
  return fit<T>(p, q, w, method, false, "fit_rigid");
}

template <class T>
SimilarityTransform<T> fit_similarity(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                                      const Weights<T>& w, RotationMethod method) {
  return fit<T>(p, q, w, method, true, "fit_similarity");
}

template SimilarityTransform<float> fit_rigid<float>(const Eigen::Ref<const Points<float>>&,
                                                     const Eigen::Ref<const Points<float>>&, const Weights<float>&,
                                                     RotationMethod);
template SimilarityTransform<double> fit_rigid<double>(const Eigen::Ref<const Points<double>>&,
                                                       const Eigen::Ref<const Points<double>>&, const Weights<double>&,
                                                       RotationMethod);
template SimilarityTransform<float> fit_similarity<float>(const Eigen::Ref<const Points<float>>&,
                                                          const Eigen::Ref<const Points<float>>&, const Weights<float>&,
                                                          RotationMethod);
template SimilarityTransform<double> fit_similarity<double>(const Eigen::Ref<const Points<double>>&,
                                                            const Eigen::Ref<const Points<double>>&,
                                                            const Weights<double>&, RotationMethod);

}  // namespace mlsdeform
