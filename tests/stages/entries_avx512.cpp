// The stage entries for AVX-512 (F), compiled with the kernels' flags for it (kernels/CMakeLists.txt).
#define MLSDEFORM_ISA_ARCH xsimd::avx512f
#define MLSDEFORM_ISA_NAME avx512
#include "tests/stages/lane_entries.inc"
