// SSE4.2 instantiation of the kernels (compiled with -msse4.2 only here).
#define MLSDEFORM_ISA_ARCH xsimd::sse4_2
#define MLSDEFORM_ISA_NAME sse4_2
#include "kernels/isa_instance.inc"
