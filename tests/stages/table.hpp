// What the stage tests (tests/test_stages.cpp, tests/test_stages_ring.cpp) share: the table of an ISA's stage
// entries, and Higham's gamma_k = k eps / (1 - k eps), the bound on k rounded operations, in long double.
#pragma once

#include "tests/stages/layouts.hpp"

#include <mlsdeform/dispatch.hpp>

#include <limits>

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
  switch (isa) {
    case Isa::sse4_2:
      return sse4_2_entries<T>();
#ifndef __EMSCRIPTEN__  // WebAssembly runs the SSE4.2 twins only (kernels/CMakeLists.txt)
    case Isa::avx2:
      return avx2_entries<T>();
    case Isa::avx512:
      return avx512_entries<T>();
#else
    case Isa::avx2:
    case Isa::avx512:
#endif
    case Isa::scalar:
      break;
  }
  return scalar_entries<T>();
}

}  // namespace mlsdeform::testing::stages
