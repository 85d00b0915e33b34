// mlsdeform: the weighted rotation fit (absolute orientation) at the heart of as-rigid-as-possible MLS.
//
// Convention. Column vectors throughout: H = sum_i w_i qhat_i phat_i^T (3x3), and fit_rotation returns the
// proper rotation R (R^T R = I, det R = +1) that maximises trace(R^T H), i.e. minimises
// sum_i w_i |R phat_i - qhat_i|^2.
//
// Mapping to the paper (Cuno et al., Sec. 4). The paper uses row vectors, l_v(x) = x R_paper + T, and its
// correlation matrix M (eq. 6) is M_jk = sum_i w_i qhat_ij phat_ik, which is exactly our H. The paper's
// rotation acts on rows, so R_paper = R^T. The paper's vector V = sum_i w_i phat_i x qhat_i (eq. 6) equals
// (H32 - H23, H13 - H31, H21 - H12). (Its eq. (4) writes qhat R phat^T where expanding (3) gives
// phat R qhat^T; with H = sum q p^T, taking eq. (15)'s sin(alpha) = -2|u|/(1+|u|^2) literally yields R^T.)
#pragma once

#include <mlsdeform/enums.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

namespace mlsdeform {

/// All methods, in declaration order (handy for tests, benchmarks and reports).
inline constexpr RotationMethod all_rotation_methods[] = {RotationMethod::axis_angle, RotationMethod::horn_quaternion,
                                                          RotationMethod::horn_matrix, RotationMethod::kanatani,
                                                          RotationMethod::svd};

/// "axis_angle", "horn_quaternion", ...; and the inverse (throws std::invalid_argument on an unknown name).
std::string_view to_string(RotationMethod method);
RotationMethod rotation_method_from_string(std::string_view name);

template <class T>
using Matrix3 = Eigen::Matrix<T, 3, 3>;
template <class T>
using Vector3 = Eigen::Matrix<T, 3, 1>;

/// The proper rotation maximising trace(R^T H). Defined for every finite H: H = 0 gives the identity; where
/// the optimum is not unique (rank-1 H, some reflected or degenerate H) a rotation attaining the optimal
/// trace is returned (for axis_angle: the one closest to the identity). Scaling H by any positive factor
/// that keeps it finite does not change the result (axis_angle: bitwise for powers of two).
/// Throws std::invalid_argument if H has a NaN or infinite entry.
template <class T>
Matrix3<T> fit_rotation(const Matrix3<T>& H, RotationMethod method = RotationMethod::axis_angle);

extern template Matrix3<float> fit_rotation<float>(const Matrix3<float>&, RotationMethod);
extern template Matrix3<double> fit_rotation<double>(const Matrix3<double>&, RotationMethod);

/// fit_rotation of any 3 x 3 Eigen expression with float or double entries (q * p.transpose(), a block, a
/// row-major or dynamic-size matrix), evaluated into a Matrix3 first. Throws std::invalid_argument if a
/// dynamic-size argument is not 3 x 3.
template <class Derived>
requires(!std::is_same_v<Derived, Matrix3<typename Derived::Scalar>>) Matrix3<typename Derived::Scalar> fit_rotation(
    const Eigen::MatrixBase<Derived>& H, RotationMethod method = RotationMethod::axis_angle) {
  using T = typename Derived::Scalar;
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>, "fit_rotation: float or double entries");
  static_assert(Derived::RowsAtCompileTime == 3 || Derived::RowsAtCompileTime == Eigen::Dynamic,
                "fit_rotation: H must have 3 rows");
  static_assert(Derived::ColsAtCompileTime == 3 || Derived::ColsAtCompileTime == Eigen::Dynamic,
                "fit_rotation: H must have 3 columns");
  if (H.rows() != 3 || H.cols() != 3)
    throw std::invalid_argument("fit_rotation: H must be 3 x 3 (got " + std::to_string(H.rows()) + " x " +
                                std::to_string(H.cols()) + ")");
  return fit_rotation<T>(Matrix3<T>(H), method);
}

}  // namespace mlsdeform
