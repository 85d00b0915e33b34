// The scalar reference's table of stage entries (baseline flags, like core/): the rotation stages of
// core/src/rotation/ one matrix at a time, the deformer's stage bodies at width 1 (deformer_entries.hpp) and
// the ARAP local step's sums over the CSR one-rings (core/src/arap/ring_correlation.hpp).
#include "tests/stages/deformer_entries.hpp"
#include "tests/stages/layouts.hpp"

#include "core/src/arap/ring_correlation.hpp"
#include "core/src/deformer/reference.hpp"
#include "core/src/rotation/axis_angle.hpp"

namespace mlsdeform::testing::stages {

namespace {

template <class T>
Matrix3<T> matrix(const T (&h)[9]) {
  Matrix3<T> H;
  for (int e = 0; e < 9; ++e) H(e / 3, e % 3) = h[e];
  return H;
}

template <class T>
struct RotationEntries {
  using L = detail::ScalarLanes<T>;

  static void invariants(const Matrix<T>* in, InvariantsOut<T>* out, std::size_t n) {
    for_lanes<L, Matrix, InvariantsOut>(in, out, n, [](const Matrix<T>& x, InvariantsOut<T>& y) {
      const detail::Invariants<T> inv = detail::invariants(matrix(x.h));
      y = {inv.E, {inv.z(0), inv.z(1), inv.z(2)}, inv.norm2, inv.det, inv.c2};
    });
  }
  static void maximum_root(const InvariantsOut<T>* in, RootOut<T>* out, std::size_t n) {
    for_lanes<L, InvariantsOut, RootOut>(in, out, n, [](const InvariantsOut<T>& x, RootOut<T>& y) {
      const detail::Invariants<T> inv = {x.E_, Vector3<T>(x.z[0], x.z[1], x.z[2]), x.norm2, x.det, x.c2};
      bool converged;
      y.y = detail::maximum_root(inv, converged);
      y.converged = converged ? T(1) : T(0);
    });
  }
  static void rotation_axis(const AxisIn<T>* in, AxisOut<T>* out, std::size_t n) {
    for_lanes<L, AxisIn, AxisOut>(in, out, n, [](const AxisIn<T>& x, AxisOut<T>& y) {
      const Matrix3<T> H = matrix(x.h);
      const detail::Vector4<T> q = detail::rotation_axis(detail::davenport(H, detail::invariants(H)), x.y, y.dk);
      for (int k = 0; k < 4; ++k) y.q[k] = q(k);
    });
  }
  static void top_eigenvector(const Matrix<T>* in, Quaternion<T>* out, std::size_t n) {
    for_lanes<L, Matrix, Quaternion>(in, out, n, [](const Matrix<T>& x, Quaternion<T>& y) {
      const Matrix3<T> H = matrix(x.h);
      const detail::Matrix4<T> K = detail::davenport(H, detail::invariants(H));
      const detail::Vector4<T> q = detail::top_eigenvector(K, K.norm());  // as the fit passes it
      for (int k = 0; k < 4; ++k) y.q[k] = q(k);
    });
  }
  static void sin_cos(const Quaternion<T>* in, Rotation<T>* out, std::size_t n) {
    for_lanes<L, Quaternion, Rotation>(in, out, n, [](const Quaternion<T>& x, Rotation<T>& y) {
      const Matrix3<T> R = detail::sin_cos(detail::Vector4<T>(x.q[0], x.q[1], x.q[2], x.q[3]));
      for (int e = 0; e < 9; ++e) y.r[e] = R(e / 3, e % 3);
    });
  }
};

}  // namespace

template <class T>
const StageEntries<T>& scalar_entries() {
  static const StageEntries<T> table = DeformerEntries<detail::ScalarLanes<T>>::template table<RotationEntries<T>>(
      "scalar", &detail::ring_correlation<T>, &detail::ring_rhs<T>);
  return table;
}
template const StageEntries<float>& scalar_entries<float>();
template const StageEntries<double>& scalar_entries<double>();

}  // namespace mlsdeform::testing::stages
