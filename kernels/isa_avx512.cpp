// AVX-512 (F) instantiation of the kernels. It compiles here but this machine (Zen 3) cannot run it:
// selected at run time only on CPUs reporting AVX-512F, and UNTESTED.
#define MLSDEFORM_ISA_ARCH xsimd::avx512f
#define MLSDEFORM_ISA_NAME avx512
#include "isa_instance.inc"
