// AVX2 + FMA instantiation of the kernels (compiled with -mavx2 -mfma only here).
#define MLSDEFORM_ISA_ARCH xsimd::fma3<xsimd::avx2>
#define MLSDEFORM_ISA_NAME avx2
#include "kernels/isa_instance.inc"
