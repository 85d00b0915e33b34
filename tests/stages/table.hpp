// What the stage tests (tests/test_stages.cpp, tests/test_stages_ring.cpp) share: the table of an ISA's stage
// entries, a loop over the SIMD ones, and Higham's gamma_k = k eps / (1 - k eps), the bound on k rounded operations, in
// long double.
#pragma once

#include "tests/stages/layouts.hpp"

#include <mlsdeform/dispatch.hpp>

#include "tests/support/catch.hpp"

#include <limits>
#include <string>

namespace mlsdeform::testing::stages {

using LD = long double;

template <class T>
LD gamma(int k) {
  const LD e = std::numeric_limits<T>::epsilon();
  return k * e / (1 - k * e);
}

/// The table of an ISA's stage entries.
template <class T>
const StageEntries<T>& entries(Isa isa) {
  switch (isa) {  // the architecture's tables only (kernels/CMakeLists.txt)
#if defined(__EMSCRIPTEN__) || defined(__x86_64__) || defined(__i386__)
    case Isa::sse4_2:
      return sse4_2_entries<T>();
#endif
#if (defined(__x86_64__) || defined(__i386__)) && !defined(__EMSCRIPTEN__)
    case Isa::avx2:
      return avx2_entries<T>();
    case Isa::avx512:
      return avx512_entries<T>();
#endif
#if defined(__aarch64__)
    case Isa::neon:
      return neon_entries<T>();
#endif
    default:
      break;
  }
  return scalar_entries<T>();
}

/// Runs check(simd, scalar) for the stage table of every SIMD ISA the CPU runs.
template <class T, class Check>
void for_each_simd_table(Check check) {
  const StageEntries<T>& scalar = scalar_entries<T>();
  int isas = 0;
  for (Isa isa : supported_isas()) {
    if (isa == Isa::scalar) continue;
    const StageEntries<T>& simd = entries<T>(isa);
    REQUIRE(std::string(simd.isa) == std::string(to_string(isa)));
    INFO("ISA " << to_string(isa));
    check(simd, scalar);
    ++isas;
  }
  if (isas == 0) WARN("no SIMD instruction set on this CPU: only the scalar table exists");
}

}  // namespace mlsdeform::testing::stages
