#include <mlsdeform/point_fit.hpp>

#include <stdexcept>
#include <string>

namespace mlsdeform {

namespace {

template <class T>
using Weights = Eigen::Ref<const Eigen::Matrix<T, Eigen::Dynamic, 1>>;

// Weighted centroids (eq. 2), H = sum w qhat phat^T (eq. 6, column convention) and sum w |phat|^2.
template <class T>
SimilarityTransform<T> fit(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                           const Weights<T>& w, RotationMethod method, bool with_scale) {
  const Eigen::Index n = p.rows();
  if (n == 0) throw std::invalid_argument("fit: no points");
  if (q.rows() != n)
    throw std::invalid_argument("fit: p has " + std::to_string(n) + " points but q has " + std::to_string(q.rows()));
  if (w.size() != 0 && w.size() != n)
    throw std::invalid_argument("fit: " + std::to_string(n) + " points but " + std::to_string(w.size()) + " weights");
  if (!p.allFinite() || !q.allFinite() || !w.allFinite())
    throw std::invalid_argument("fit: non-finite coordinate or weight");
  if (w.size() != 0 && (w.array() < T(0)).any()) throw std::invalid_argument("fit: negative weight");
  Eigen::Matrix<T, Eigen::Dynamic, 1> wn =
      w.size() ? Eigen::Matrix<T, Eigen::Dynamic, 1>(w) : Eigen::Matrix<T, Eigen::Dynamic, 1>::Ones(n);
  const T wmax = wn.maxCoeff();
  if (!(wmax > T(0))) throw std::invalid_argument("fit: the weights sum to zero");
  wn /= wmax;      // first by the largest, so that the sum cannot overflow (weights near the float maximum)
  wn /= wn.sum();  // normalised weights: the fit is invariant under their scale
  const Vector3<T> p_star = p.transpose() * wn, q_star = q.transpose() * wn;
  const Points<T> phat = p.rowwise() - p_star.transpose();
  const Points<T> qhat = q.rowwise() - q_star.transpose();
  const Matrix3<T> H = qhat.transpose() * wn.asDiagonal() * phat;
  SimilarityTransform<T> t;
  t.rotation = fit_rotation<T>(H, method);
  if (with_scale) {
    const T spread = (phat.array().square().rowwise().sum().matrix().transpose() * wn)(0);
    // Sec. 6.1: mu_s = y / sum w |phat|^2 with y = trace(R^T H), the optimal value.
    t.scale = spread > T(0) ? (t.rotation.transpose() * H).trace() / spread : T(1);
  }
  t.translation = q_star - t.scale * (t.rotation * p_star);
  return t;
}

}  // namespace

template <class T>
SimilarityTransform<T> fit_rigid(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                                 const Weights<T>& w, RotationMethod method) {
  return fit<T>(p, q, w, method, false);
}

template <class T>
SimilarityTransform<T> fit_similarity(const Eigen::Ref<const Points<T>>& p, const Eigen::Ref<const Points<T>>& q,
                                      const Weights<T>& w, RotationMethod method) {
  return fit<T>(p, q, w, method, true);
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
