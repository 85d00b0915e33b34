// mlsdeform: the run-time choice of instruction set (core/src/dispatch.cpp). The library is compiled once for
// the architecture's baseline (generic x86-64, or aarch64); the kernels of every set of that architecture
// below are in it, and the best one the CPU runs is picked.
#pragma once

#include <cstddef>
#include <string_view>
#include <vector>

namespace mlsdeform {

/// Instruction sets the kernels are built for; `scalar` is the scalar reference, an entry of the dispatch
/// like any other. x86-64 has sse4_2, avx2 and avx512; aarch64 has neon (NEON is part of its baseline, so
/// every aarch64 CPU runs it). The environment variable MLSDEFORM_ISA=scalar|sse4_2|avx2|avx512|neon forces
/// one (read once, at the first call that needs it; an unknown value, or one of another architecture, throws).
/// The tests run every ISA the CPU reports (avx512 wherever it has AVX-512F); set_isa or MLSDEFORM_ISA=avx2
/// reproduces an AVX2-only machine.
enum class Isa { scalar, sse4_2, avx2, avx512, neon };

std::string_view to_string(Isa isa);
/// The instruction sets this CPU can run, best last (scalar is always there).
std::vector<Isa> supported_isas();
/// The one in use.
Isa active_isa();
/// Force one (throws std::invalid_argument if this CPU cannot run it). Not thread-safe against running fits.
void set_isa(Isa isa);
/// SIMD lanes of the active ISA for T = float or double (1 for scalar).
template <class T>
std::size_t simd_lanes();

extern template std::size_t simd_lanes<float>();
extern template std::size_t simd_lanes<double>();

}  // namespace mlsdeform
