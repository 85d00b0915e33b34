// AVX-512 (F) instantiation of the kernels, selected at run time on CPUs reporting AVX-512F (and FMA); the
// agreement tests run it wherever the CPU has it.
#define MLSDEFORM_ISA_ARCH xsimd::avx512f
#define MLSDEFORM_ISA_NAME avx512
#include "kernels/isa_instance.inc"
