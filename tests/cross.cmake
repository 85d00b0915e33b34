# A cross build's program run (tests/CMakeLists.txt includes this file there only): the command-line program
# under the emulator deforms the bundled human by its handles file; it must exit 0 and name the target's best
# SIMD table in its own report ("deformer: rigid, ..., simd (neon) backend, ..." on aarch64).
if(NOT MLSDEFORM_BUILD_TOOLS)
  return()
endif()
set(_best scalar)
if(MLSDEFORM_ISAS)
  list(GET MLSDEFORM_ISAS -1 _best)  # the best last (kernels/CMakeLists.txt)
endif()
# `deform` rather than `demo`: the demo times every scene on both backends, 20 minutes and more under qemu.
add_test(NAME cross:deform
         COMMAND ${CMAKE_COMMAND} "-DCOMMAND=${CMAKE_CROSSCOMPILING_EMULATOR};$<TARGET_FILE:mlsdeform>;deform;-m;${PROJECT_SOURCE_DIR}/data/human_man.obj;-H;${PROJECT_SOURCE_DIR}/data/human_bend.json;-o;${CMAKE_CURRENT_BINARY_DIR}/cross_human_bent.obj;--force"
                 "-DEXPECT=simd (${_best}) backend" -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/run_expect.cmake)
set_tests_properties(cross:deform PROPERTIES LABELS "cli;cross" TIMEOUT 900)
