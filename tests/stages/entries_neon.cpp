// The stage entries for NEON (aarch64), compiled with the kernels' flags for it (kernels/CMakeLists.txt).
#define MLSDEFORM_ISA_ARCH xsimd::neon64
#define MLSDEFORM_ISA_NAME neon
#include "tests/stages/lane_entries.inc"
