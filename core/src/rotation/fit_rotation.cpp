#include "core/src/rotation/axis_angle.hpp"
#include "core/src/rotation/baselines.hpp"

#include <mlsdeform/rotation.hpp>

#include <limits>
#include <stdexcept>
#include <string>

namespace mlsdeform {

namespace {
constexpr std::string_view kNames[] = {"axis_angle", "horn_quaternion", "horn_matrix", "kanatani", "svd"};
}

std::string_view to_string(RotationMethod method) { return kNames[static_cast<int>(method)]; }

RotationMethod rotation_method_from_string(std::string_view name) {
  for (RotationMethod m : all_rotation_methods)
    if (to_string(m) == name) return m;
  throw std::invalid_argument("unknown rotation method '" + std::string(name) +
                              "' (expected axis_angle, horn_quaternion, horn_matrix, kanatani or svd)");
}

template <class T>
Matrix3<T> fit_rotation(const Matrix3<T>& H, RotationMethod method) {
  if (!H.allFinite()) throw std::invalid_argument("fit_rotation: H has a NaN or infinite entry");
  const T m = H.cwiseAbs().maxCoeff();
  if (m == T(0)) return Matrix3<T>::Identity();
  // Exact power-of-two normalisation (max |H_ij| in [1, 2)) for every method: no overflow or underflow in
  // products such as det(H)^2, and power-of-two scalings of H give bitwise identical results.
  // By products with powers of two (exact; std::ldexp per entry cost ~30 ns of a ~130 ns fit). For a
  // subnormal m the factor 2^-ilogb(m) itself would overflow: then two factors.
  const int e = std::ilogb(m);
  constexpr int emax = std::numeric_limits<T>::max_exponent - 1;  // 127 or 1023
  Matrix3<T> Hn = H;
  if (-e > emax)
    Hn *= std::ldexp(T(1), emax), Hn *= std::ldexp(T(1), -e - emax);
  else
    Hn *= std::ldexp(T(1), -e);
  switch (method) {
    case RotationMethod::axis_angle:
      return detail::fit_rotation_axis_angle(Hn);
    case RotationMethod::horn_quaternion:
      return detail::fit_rotation_horn_quaternion(Hn);
    case RotationMethod::horn_matrix:
      return detail::fit_rotation_horn_matrix(Hn);
    case RotationMethod::kanatani:
      return detail::fit_rotation_kanatani(Hn);
    case RotationMethod::svd:
      return detail::fit_rotation_svd(Hn);
  }
  throw std::invalid_argument("fit_rotation: unknown RotationMethod value " + std::to_string(static_cast<int>(method)));
}

template Matrix3<float> fit_rotation<float>(const Matrix3<float>&, RotationMethod);
template Matrix3<double> fit_rotation<double>(const Matrix3<double>&, RotationMethod);

}  // namespace mlsdeform
