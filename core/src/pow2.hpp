// Exact scaling by powers of two. A problem whose numbers are multiplied by 2^-e, e taken from the problem's
// own magnitudes, runs on numbers of order one: nothing overflows or underflows at any input scale, and since
// a product with a power of two is exact (away from the subnormal range), scaling the whole input by 2^k
// shifts e by k and leaves every number of the scaled problem bitwise the same.
#pragma once

#include <cmath>

namespace mlsdeform::detail {

/// The exponent e of the largest magnitude m of a problem, m in [2^e, 2^(e+1)) (std::ilogb: subnormal m
/// included); 0 for m = 0.
template <class T>
int exponent_of(T m) {
  return m > T(0) ? std::ilogb(m) : 0;
}

}  // namespace mlsdeform::detail
