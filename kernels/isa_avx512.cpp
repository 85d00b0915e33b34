// AVX-512 (F) instantiation of the kernels, selected at run time on CPUs reporting AVX-512F. The
// development machine (AMD EPYC, Zen 4) has it, so every agreement test runs this path there.
#define MLSDEFORM_ISA_ARCH xsimd::avx512f
#define MLSDEFORM_ISA_NAME avx512
#include "isa_instance.inc"
