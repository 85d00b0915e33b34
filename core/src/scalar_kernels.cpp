// The scalar reference as an entry of the kernel table (kernels/kernel_table.hpp), like any ISA: the rotation
// fits one matrix at a time (fit_rotation), the deformer's reference (deformer/reference.hpp) and the ARAP
// steps' one-ring sums over the CSR one-rings (arap/ring_correlation.hpp), over the same layouts and the same
// frames as the SIMD kernels. Compiled with the baseline flags.
#include "core/src/arap/ring_correlation.hpp"
#include "core/src/deformer/reference.hpp"

#include "kernels/all_finite.hpp"
#include "kernels/kernel_table.hpp"

#include <mlsdeform/rotation.hpp>

namespace mlsdeform {

namespace detail {

/// Matrices [begin, end) of a 3 x 3 x n layout, one at a time. BatchStats are for lanes: nothing to add.
template <class T>
void fit_rotations_one_at_a_time(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end,
                                 RotationMethod method) {
  for (std::size_t i = begin; i < end; ++i) {
    Matrix3<T> Hi;
    for (std::size_t e = 0; e < 9; ++e) Hi(e / 3, e % 3) = H[e * stride + i];
    const Matrix3<T> Ri = fit_rotation<T>(Hi, method);
    for (std::size_t e = 0; e < 9; ++e) R[e * stride + i] = Ri(e / 3, e % 3);
  }
}

template void fit_rotations_one_at_a_time<float>(const float*, float*, std::size_t, std::size_t, std::size_t,
                                                 RotationMethod);
template void fit_rotations_one_at_a_time<double>(const double*, double*, std::size_t, std::size_t, std::size_t,
                                                  RotationMethod);

namespace {

template <class T, RotationMethod method>
void fit_entry(const T* H, T* R, std::size_t stride, std::size_t begin, std::size_t end, BatchStats*) {
  fit_rotations_one_at_a_time(H, R, stride, begin, end, method);
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
      &detail::fit_entry<float, RotationMethod::axis_angle>,  // the scalar reference writes as it goes
      &detail::fit_entry<double, RotationMethod::axis_angle>,
      &detail::fit_entry<float, RotationMethod::horn_quaternion>,
      &detail::fit_entry<double, RotationMethod::horn_quaternion>,
      &detail::deform_blocks_reference<float>,
      &detail::deform_blocks_reference<double>,
      &detail::ring_correlation<float>,
      &detail::ring_correlation<double>,
      &detail::ring_rhs<float>,
      &detail::ring_rhs<double>,
      &all_finite<float>,
      &all_finite<double>,
  };
  return table;
}

}  // namespace kernels

}  // namespace mlsdeform
