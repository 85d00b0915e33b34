// Counting floating-point operations of a templated scalar algorithm: Counted<T> behaves as T and tallies
// every +, -, *, / and sqrt (and, apart, the transcendental calls) in thread-local counters. The roofline
// benchmark runs the library's scalar reference of the axis/angle fit (core/src/rotation/axis_angle.hpp) on it over
// the benchmark's matrices, which gives the flops per fit of the algorithm as written (Newton iterations
// and rare branches included, averaged). This machine's virtualised CPU exposes no hardware counters
// (no PMU in the guest), so this is how flops are counted here.
//
// Conventions: an FMA in the real code is two operations here (as in the peak, which counts 2 per FMA);
// comparisons and selects are not counted. Operators are templates that match Counted exactly, so they
// win over the built-in arithmetic an implicit conversion to T would otherwise allow; the conversion to T
// is there for the odd qualified std:: call on a constant (std::cbrt(eps)), which then runs uncounted.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace bench {

struct FlopTally {
  std::uint64_t add = 0, mul = 0, div = 0, sqrt = 0, transcendental = 0;
  std::uint64_t flops() const { return add + mul + div + sqrt; }
};

inline thread_local FlopTally flop_tally;

template <class T>
struct Counted {
  T v{};
  constexpr Counted() = default;
  template <class U, class = std::enable_if_t<std::is_arithmetic_v<U>>>
  constexpr Counted(U x) : v(static_cast<T>(x)) {}
  constexpr operator T() const { return v; }

  Counted& operator+=(Counted o) { return ++flop_tally.add, v += o.v, *this; }
  Counted& operator-=(Counted o) { return ++flop_tally.add, v -= o.v, *this; }
  Counted& operator*=(Counted o) { return ++flop_tally.mul, v *= o.v, *this; }
  Counted& operator/=(Counted o) { return ++flop_tally.div, v /= o.v, *this; }
  Counted operator-() const { return Counted(-v); }  // a sign flip, free
  Counted operator+() const { return *this; }
};

template <class X>
struct is_counted : std::false_type {};
template <class T>
struct is_counted<Counted<T>> : std::true_type {};

/// The Counted type of a pair of operands (at least one Counted, the other Counted or arithmetic).
template <class A, class B>
using counted_of = std::conditional_t<is_counted<A>::value, A, B>;
template <class A, class B>
concept CountedPair = (is_counted<A>::value && (is_counted<B>::value || std::is_arithmetic_v<B>)) ||
                      (is_counted<B>::value && std::is_arithmetic_v<A>);

// The four arithmetic operators, each counted in its tally.
#define BENCH_COUNTED_ARITHMETIC(op, tally)   \
  template <class A, class B>                 \
  requires CountedPair<A, B> counted_of<A, B> \
  operator op(A a, B b) {                     \
    using C = counted_of<A, B>;               \
    ++flop_tally.tally;                       \
    return C(C(a).v op C(b).v);               \
  }
BENCH_COUNTED_ARITHMETIC(+, add)
BENCH_COUNTED_ARITHMETIC(-, add)
BENCH_COUNTED_ARITHMETIC(*, mul)
BENCH_COUNTED_ARITHMETIC(/, div)
#undef BENCH_COUNTED_ARITHMETIC

// The comparisons, not counted.
#define BENCH_COUNTED_COMPARE(op) \
  template <class A, class B>     \
  requires CountedPair<A, B>      \
  bool operator op(A a, B b) {    \
    using C = counted_of<A, B>;   \
    return C(a).v op C(b).v;      \
  }
BENCH_COUNTED_COMPARE(<)
BENCH_COUNTED_COMPARE(>)
BENCH_COUNTED_COMPARE(<=)
BENCH_COUNTED_COMPARE(>=)
BENCH_COUNTED_COMPARE(==)
BENCH_COUNTED_COMPARE(!=)
#undef BENCH_COUNTED_COMPARE

// Found by argument-dependent lookup from the `using std::sqrt; sqrt(x)` idiom (and Eigen's numext).
#define BENCH_COUNTED_FUNCTION(f, tally) \
  template <class T>                     \
  Counted<T> f(Counted<T> x) {           \
    ++flop_tally.tally;                  \
    return Counted<T>(std::f(x.v));      \
  }
BENCH_COUNTED_FUNCTION(sqrt, sqrt)
BENCH_COUNTED_FUNCTION(cbrt, transcendental)
BENCH_COUNTED_FUNCTION(cos, transcendental)
BENCH_COUNTED_FUNCTION(acos, transcendental)
#undef BENCH_COUNTED_FUNCTION
template <class T>
Counted<T> abs(Counted<T> x) {  // free, like a sign flip
  return Counted<T>(std::abs(x.v));
}
template <class T>
bool isfinite(Counted<T> x) {
  return std::isfinite(x.v);
}

}  // namespace bench

template <class T>
class std::numeric_limits<bench::Counted<T>> : public std::numeric_limits<T> {
 public:
  static constexpr bench::Counted<T> epsilon() noexcept { return std::numeric_limits<T>::epsilon(); }
  static constexpr bench::Counted<T> infinity() noexcept { return std::numeric_limits<T>::infinity(); }
  static constexpr bench::Counted<T> quiet_NaN() noexcept { return std::numeric_limits<T>::quiet_NaN(); }
  static constexpr bench::Counted<T> max() noexcept { return std::numeric_limits<T>::max(); }
  static constexpr bench::Counted<T> min() noexcept { return std::numeric_limits<T>::min(); }
  static constexpr bench::Counted<T> lowest() noexcept { return std::numeric_limits<T>::lowest(); }
  static constexpr bench::Counted<T> denorm_min() noexcept { return std::numeric_limits<T>::denorm_min(); }
};

namespace Eigen {
template <class T>
struct NumTraits<bench::Counted<T>> : GenericNumTraits<bench::Counted<T>> {
  using Real = bench::Counted<T>;
  using NonInteger = bench::Counted<T>;
  using Nested = bench::Counted<T>;
  using Literal = bench::Counted<T>;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 0,
    ReadCost = 1,
    AddCost = 1,
    MulCost = 1
  };
  static inline Real epsilon() { return NumTraits<T>::epsilon(); }
  static inline Real dummy_precision() { return NumTraits<T>::dummy_precision(); }
  static inline Real highest() { return NumTraits<T>::highest(); }
  static inline Real lowest() { return NumTraits<T>::lowest(); }
  static inline int digits10() { return NumTraits<T>::digits10(); }
};
}  // namespace Eigen
