#include "core/src/dispatch.hpp"

#include <atomic>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace mlsdeform {

namespace {

constexpr Isa kAllIsas[] = {Isa::scalar, Isa::sse4_2, Isa::avx2, Isa::avx512, Isa::neon};
constexpr std::string_view kIsaNames[] = {"scalar", "sse4_2", "avx2", "avx512", "neon"};

// The architecture's kernels are the only ones built (kernels/CMakeLists.txt); an ISA of another is never run.
bool cpu_runs(Isa isa) {
  if (isa == Isa::scalar) return true;
#if defined(__EMSCRIPTEN__)
  // WebAssembly: the sse4_2 twins compiled to 128-bit WebAssembly SIMD (emscripten translates the SSE
  // intrinsics), which every engine that loads the module runs; there is no wider vector in WebAssembly.
  return isa == Isa::sse4_2;
#elif defined(__x86_64__) || defined(__i386__)
  // GCC's __builtin_cpu_supports also checks that the OS saves the wider registers (XCR0).
  switch (isa) {
    case Isa::sse4_2:
      return __builtin_cpu_supports("sse4.2");
    case Isa::avx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::avx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::scalar:
    case Isa::neon:
      break;
  }
  return false;
#elif defined(__aarch64__)
  // Advanced SIMD (NEON, with fused multiply-add) is part of the aarch64 baseline: no run-time check.
  return isa == Isa::neon;
#else
  return false;  // another architecture: the scalar reference only
#endif
}

Isa isa_from_string(std::string_view name) {
  for (Isa isa : kAllIsas)
    if (kIsaNames[static_cast<int>(isa)] == name) return isa;
  throw std::invalid_argument("MLSDEFORM_ISA='" + std::string(name) +
                              "' is not one of scalar, sse4_2, avx2, avx512, neon");
}

Isa initial_isa() {
  if (const char* forced = std::getenv("MLSDEFORM_ISA"); forced && *forced) {
    const Isa isa = isa_from_string(forced);
    if (!cpu_runs(isa))
      throw std::invalid_argument("MLSDEFORM_ISA=" + std::string(forced) + ": this CPU cannot run it");
    return isa;
  }
  for (Isa isa : {Isa::avx512, Isa::avx2, Isa::sse4_2, Isa::neon})  // best first; no allocation on the first deform()
    if (cpu_runs(isa)) return isa;
  return Isa::scalar;
}

std::atomic<int>& current() {
  static std::atomic<int> isa{static_cast<int>(initial_isa())};
  return isa;
}

}  // namespace

std::string_view to_string(Isa isa) { return kIsaNames[static_cast<int>(isa)]; }

std::vector<Isa> supported_isas() {
  std::vector<Isa> out;
  for (Isa isa : kAllIsas)
    if (cpu_runs(isa)) out.push_back(isa);
  return out;
}

Isa active_isa() { return static_cast<Isa>(current().load(std::memory_order_relaxed)); }

void set_isa(Isa isa) {
  if (!cpu_runs(isa))
    throw std::invalid_argument("set_isa(" + std::string(to_string(isa)) + "): this CPU cannot run it");
  current().store(static_cast<int>(isa), std::memory_order_relaxed);
}

template <class T>
std::size_t simd_lanes() {
  const kernels::KernelTable& k = detail::active_kernels();
  return std::is_same_v<T, double> ? k.lanes_double : k.lanes_float;
}

template std::size_t simd_lanes<float>();
template std::size_t simd_lanes<double>();

namespace detail {

const kernels::KernelTable& active_kernels() { return kernels_for(active_isa()); }

const kernels::KernelTable& kernels_for(Isa isa) {
  // Only the tables of this architecture are compiled (kernels/CMakeLists.txt); cpu_runs never lets another
  // be asked, and asked anyway it is the scalar reference.
  switch (isa) {
#if defined(__EMSCRIPTEN__) || defined(__x86_64__) || defined(__i386__)
    case Isa::sse4_2:
      return kernels::kernel_table_sse4_2();
#endif
#if (defined(__x86_64__) || defined(__i386__)) && !defined(__EMSCRIPTEN__)
    case Isa::avx2:
      return kernels::kernel_table_avx2();
    case Isa::avx512:
      return kernels::kernel_table_avx512();
#endif
#if defined(__aarch64__)
    case Isa::neon:
      return kernels::kernel_table_neon();
#endif
    default:
      break;
  }
  return kernels::kernel_table_scalar();
}

}  // namespace detail

}  // namespace mlsdeform
