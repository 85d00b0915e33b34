// The stage entries for SSE4.2, compiled with the kernels' flags for it (kernels/CMakeLists.txt).
#define MLSDEFORM_ISA_ARCH xsimd::sse4_2
#define MLSDEFORM_ISA_NAME sse4_2
#include "tests/stages/lane_entries.inc"
