// The scalar reference as an entry of the kernel table (kernels/kernel_table.hpp), like any ISA: the rotation
// fits one matrix at a time (fit_rotation) and the deformer's reference (deformer/reference.hpp), over the
// same layouts and the same DeformFrame as the SIMD kernels. Compiled with the baseline flags.
#include "core/src/deformer/reference.hpp"
#include "core/src/rotation/axis_angle.hpp"

#include "kernels/kernel_table.hpp"

#include <mlsdeform/rotation.hpp>

namespace mlsdeform {

namespace detail {

/// Matrices [begin, end) of a 3 x 3 x n layout, one at a time. BatchStats are for lanes: nothing to add.
template <class T>
void fit_rotations_reference(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end,
                             RotationMethod method) {
  for (std::size_t i = begin; i < end; ++i) {
    Matrix3<T> Hi;
    for (std::size_t e = 0; e < 9; ++e) Hi(e / 3, e % 3) = H[e * stride + i];
    const Matrix3<T> Ri = fit_rotation<T>(Hi, method);
    for (std::size_t e = 0; e < 9; ++e) R[e * stride + i] = Ri(e / 3, e % 3);
  }
}

template void fit_rotations_reference<float>(const float*, float*, std::size_t, std::size_t, std::size_t,
                                             RotationMethod);
template void fit_rotations_reference<double>(const double*, double*, std::size_t, std::size_t, std::size_t,
                                              RotationMethod);

namespace {

template <class T, RotationMethod method>
void fit_entry(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end, BatchStats*) {
  fit_rotations_reference(H, R, stride, begin, end, method);
}

/// The StageFn entry: one stage on n lanes, one lane at a time (layouts: enum Stage in contract.hpp).
template <class T>
void run_stage(kernels::Stage stage, const T* in, const T* shared, std::size_t J, T* out, std::size_t n) {
  using kernels::Stage;
  for (std::size_t i = 0; i < n; ++i) {
    auto x = [&](std::size_t k) { return in[k * n + i]; };
    auto put = [&](std::size_t k, T v) { out[k * n + i] = v; };
    auto matrix = [&](std::size_t first) {
      Matrix3<T> H;
      for (int e = 0; e < 9; ++e) H(e / 3, e % 3) = x(first + e);
      return H;
    };
    switch (stage) {
      case Stage::invariants: {
        const Invariants<T> inv = invariants(matrix(0));
        const T o[7] = {inv.E, inv.z[0], inv.z[1], inv.z[2], inv.norm2, inv.det, inv.c2};
        for (std::size_t k = 0; k < 7; ++k) put(k, o[k]);
        break;
      }
      case Stage::maximum_root: {
        Invariants<T> inv;
        inv.E = x(0), inv.z = Vector3<T>(x(1), x(2), x(3)), inv.norm2 = x(4), inv.det = x(5), inv.c2 = x(6);
        bool converged;
        put(0, maximum_root(inv, converged));
        put(1, converged ? T(1) : T(0));
        break;
      }
      case Stage::rotation_axis: {
        const Matrix3<T> H = matrix(0);
        T dk;
        const Eigen::Matrix<T, 4, 1> q = rotation_axis(H, invariants(H), x(9), dk);
        for (int k = 0; k < 4; ++k) put(std::size_t(k), q(k));
        put(4, dk);
        break;
      }
      case Stage::top_eigenvector: {
        const Matrix3<T> H = matrix(0);
        const Eigen::Matrix<T, 4, 1> q = top_eigenvector(davenport(H, invariants(H)));
        for (int k = 0; k < 4; ++k) put(std::size_t(k), q(k));
        break;
      }
      case Stage::sin_cos: {
        const Matrix3<T> R = sin_cos(Eigen::Matrix<T, 4, 1>(x(0), x(1), x(2), x(3)));
        for (int e = 0; e < 9; ++e) put(std::size_t(e), R(e / 3, e % 3));
        break;
      }
      case Stage::weighted_centroid: {
        T qs[3] = {0, 0, 0};
        for (std::size_t j = 0; j < J; ++j)
          kernels::weighted_centroid(qs, x(j), {shared[3 * j], shared[3 * j + 1], shared[3 * j + 2]});
        for (std::size_t k = 0; k < 3; ++k) put(k, qs[k]);
        break;
      }
      case Stage::correlation_matrix: {
        T h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
        for (std::size_t j = 0; j < J; ++j)
          kernels::correlation_matrix(h, {shared[3 * j], shared[3 * j + 1], shared[3 * j + 2]},
                                      {x(3 * j), x(3 * j + 1), x(3 * j + 2)});
        for (std::size_t k = 0; k < 9; ++k) put(k, h[k]);
        break;
      }
      case Stage::similarity_scale: {
        T r[9], h[9];
        for (std::size_t k = 0; k < 9; ++k) r[k] = x(k), h[k] = x(9 + k);
        put(0, kernels::similarity_scale(r, h, x(18), x(19)));
        break;
      }
      case Stage::apply: {
        T qs[3], r[9], vh[3], o[3];
        for (std::size_t k = 0; k < 3; ++k) qs[k] = x(k), vh[k] = x(13 + k);
        for (std::size_t k = 0; k < 9; ++k) r[k] = x(4 + k);
        kernels::apply(qs, x(3), r, vh, o);
        for (std::size_t k = 0; k < 3; ++k) put(k, o[k]);
        break;
      }
    }
  }
}

}  // namespace

}  // namespace detail

namespace kernels {

const KernelTable& kernel_table_scalar() {
  static const KernelTable table = {
      "scalar",
      1,
      1,
      &detail::fit_entry<float, RotationMethod::axis_angle>,
      &detail::fit_entry<double, RotationMethod::axis_angle>,
      &detail::fit_entry<float, RotationMethod::horn_quaternion>,
      &detail::fit_entry<double, RotationMethod::horn_quaternion>,
      &detail::deform_blocks_reference<float>,
      &detail::deform_blocks_reference<double>,
      &detail::run_stage<float>,
      &detail::run_stage<double>,
  };
  return table;
}

}  // namespace kernels

}  // namespace mlsdeform
