// Test helpers: the architecture's instruction sets, and a guard that restores the instruction set in force when it was
// made, also when a check throws (a failing REQUIRE must not leave an ISA forced for the tests that follow).
#pragma once

#include <mlsdeform/dispatch.hpp>

#include <vector>

namespace mlsdeform::testing {

/// The SIMD instruction sets built for this architecture (kernels/CMakeLists.txt): a test warns about those
/// the CPU lacks, never about another architecture's.
inline std::vector<Isa> architecture_isas() {
#if defined(__aarch64__)
  return {Isa::neon};
#elif defined(__EMSCRIPTEN__)
  return {Isa::sse4_2};
#elif defined(__x86_64__) || defined(__i386__)
  return {Isa::sse4_2, Isa::avx2, Isa::avx512};
#else
  return {};
#endif
}

class IsaGuard {
 public:
  IsaGuard() : saved_(active_isa()) {}
  ~IsaGuard() { set_isa(saved_); }
  IsaGuard(const IsaGuard&) = delete;
  IsaGuard& operator=(const IsaGuard&) = delete;

 private:
  Isa saved_;
};

}  // namespace mlsdeform::testing
