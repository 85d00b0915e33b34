// Rotation of a splat's view-dependent colour: real spherical harmonics, bands 1-3, in 3DGS's basis.
#pragma once

#include <array>

namespace mlsdeform::detail {

/// The 15 real SH basis functions of bands 1-3 at the unit direction d, in 3DGS's order and signs (its
/// sh_utils.py: m = -l..l within a band, the Condon-Shortley phase on odd m): band 1 is C1 (-y, z, -x). They are
/// orthonormal on the unit sphere.
std::array<double, 15> sh_basis(const std::array<double, 3>& d);

/// Rotates one splat's f_rest coefficients (3 channels x k, channel-major, k = (degree + 1)^2 - 1) so that the
/// rotated colour function f' satisfies f'(R d) = f(d), i.e. f'(x) = f(R^T x); R row-major, a rotation (det +1).
/// With `mirror`, the map is -R instead (det -1), and f'(x) = f(-R^T x): band l also changes sign by (-1)^l.
/// Bands 1 and 2 in closed form: band 1's coefficients are a vector v with f_1(x) = C1 v . x, which turns as
/// R v; band 2's a symmetric traceless matrix A with f_2(x) = x^T A x, which turns as R A R^T. Band 3 is
/// projected back onto the orthonormal basis by the 26-point Lebedev rule, which integrates polynomials up to
/// degree 7 exactly on the sphere: f'_3 times a basis function of band 3 has degree 6, so the projection is exact
/// in exact arithmetic and, the basis being orthonormal, the rounding error of a coefficient is a few units of
/// double's epsilon times the band's norm (no conditioning to lose).
/// Computed in double; a float input is rounded once at the end. Allocates nothing.
template <class T>
void rotate_sh(T* sh_rest, int degree, const double R[9], bool mirror);

}  // namespace mlsdeform::detail
