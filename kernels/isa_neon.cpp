// NEON instantiation of the kernels, for aarch64 (xsimd's neon64: 128-bit Advanced SIMD, 4 floats or 2
// doubles, with fused multiply-add). NEON is part of the aarch64 baseline, so no flag is needed.
#define MLSDEFORM_ISA_ARCH xsimd::neon64
#define MLSDEFORM_ISA_NAME neon
#include "kernels/isa_instance.inc"
