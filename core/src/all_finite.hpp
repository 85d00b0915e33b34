// A vectorisable finiteness check for large arrays (the batched fits' input, the deformer's output).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace mlsdeform::detail {

/// True when every x[i] is finite, i.e. no exponent field is all ones: adding one unit of the exponent's
/// lowest bit to (bits & exponent mask) carries into the sign bit exactly then. Only and/add/or on the bit
/// patterns, which the compiler vectorises even for baseline x86-64 (the element-wise std::isfinite loop
/// with an early exit cost about 3 ns per matrix in float, 5 in double: 7% of a batched fit).
template <class T>
bool all_finite(const T* x, std::size_t count) {
  using U = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  constexpr int mantissa = std::numeric_limits<T>::digits - 1;
  constexpr U sign = U(1) << (8 * sizeof(T) - 1), exponent = (sign - 1) & ~((U(1) << mantissa) - 1);
  U bad = 0;
  // The builtin std::bit_cast is made of: the libc++ of emscripten 3.1.6 (the WebAssembly build) lacks the latter.
  for (std::size_t i = 0; i < count; ++i) bad |= (__builtin_bit_cast(U, x[i]) & exponent) + (U(1) << mantissa);
  return (bad & sign) == 0;
}

}  // namespace mlsdeform::detail
