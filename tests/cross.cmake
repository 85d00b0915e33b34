# A cross build's program run (tests/CMakeLists.txt includes this file there only): the command-line program
# under the emulator, the demo's short form, which must exit 0 and name the target's best SIMD table in its
# own report ("SIMD backend: neon, 4 lanes of float" on aarch64).
if(NOT MLSDEFORM_BUILD_TOOLS)
  return()
endif()
set(_best scalar)
if(MLSDEFORM_ISAS)
  list(GET MLSDEFORM_ISAS -1 _best)  # the best last (kernels/CMakeLists.txt)
endif()
add_test(NAME cross:demo
         COMMAND ${CMAKE_COMMAND} "-DCOMMAND=${CMAKE_CROSSCOMPILING_EMULATOR};$<TARGET_FILE:mlsdeform>;demo;--frames;2;--no-images;--out-dir;${CMAKE_CURRENT_BINARY_DIR}/cross_demo"
                 "-DEXPECT=SIMD backend: ${_best}," -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/run_expect.cmake)
set_tests_properties(cross:demo PROPERTIES LABELS cli TIMEOUT 1800)
