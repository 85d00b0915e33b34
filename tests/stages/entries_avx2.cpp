// The stage entries for AVX2 + FMA, compiled with the kernels' flags for it (kernels/CMakeLists.txt).
#define MLSDEFORM_ISA_ARCH xsimd::fma3<xsimd::avx2>
#define MLSDEFORM_ISA_NAME avx2
#include "tests/stages/lane_entries.inc"
