# The library's tests compiled to WebAssembly and run under Node (ctest in build-web/; the native build's
# `web` label runs them through tests/web.cmake): the stage twins (scalar against the SSE4.2 kernels in
# WebAssembly SIMD), the deformer against the MLS reference, and the ARAP invariants, with the native build's
# bounds unchanged. Node reads the repository's files directly (-sNODERAWFS).
if(NOT MLSDEFORM_BUILD_TESTS)
  return()
endif()
if(NOT EXISTS /usr/include/catch2/catch.hpp)
  message(STATUS "web build: no Catch2 2 single header (/usr/include/catch2/catch.hpp; Debian 13 has only "
                 "Catch2 3, a library compiled for the host): the WebAssembly C++ tests (web:test_*) are left out; "
                 "the page's tests run")
  return()
endif()
enable_testing()
set(_src ${PROJECT_SOURCE_DIR}/tests)
add_library(mlsdeform_web_test_support STATIC
  ${_src}/support/deform_cases.cpp ${_src}/support/meshes.cpp ${_src}/support/mls_reference.cpp
  ${_src}/support/quality.cpp ${_src}/support/random.cpp ${_src}/support/rotation_cases.cpp)
target_include_directories(mlsdeform_web_test_support PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(mlsdeform_web_test_support PUBLIC mlsdeform::mlsdeform PRIVATE mlsdeform_warnings)
# The tests' own code at -O1 (the library under test keeps -O3) for CI's time budget: test_deformer.cpp and
# test_arap.cpp compile in about a quarter less time (33 s -> 25 s together, loaded 2-core machine), and the
# tests still take seconds under Node.
set(_test_opt -O1)
target_compile_options(mlsdeform_web_test_support PRIVATE ${_test_opt})
target_compile_definitions(mlsdeform_web_test_support PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                                                              MLSDEFORM_NO_ZLIB=1)

# The stage entries: the scalar table and the SSE4.2 one, compiled as the kernels are.
mlsdeform_isa_object(mlsdeform_web_stage_entries_sse4_2 sse4_2 ${_src}/stages/entries_sse4_2.cpp)
add_library(mlsdeform_web_stage_entries STATIC ${_src}/stages/scalar_entries.cpp
                                               $<TARGET_OBJECTS:mlsdeform_web_stage_entries_sse4_2>)
target_include_directories(mlsdeform_web_stage_entries PRIVATE ${PROJECT_SOURCE_DIR})
target_link_libraries(mlsdeform_web_stage_entries PRIVATE mlsdeform::mlsdeform mlsdeform_warnings)

# Catch2 v2's header-only main, compiled once.
add_library(mlsdeform_web_catch_main STATIC ${PROJECT_SOURCE_DIR}/web/tests/catch_main.cpp)
target_include_directories(mlsdeform_web_catch_main SYSTEM PRIVATE ${CMAKE_BINARY_DIR}/sysdeps)  # web/cmake/deps.cmake
target_compile_options(mlsdeform_web_catch_main PRIVATE ${_test_opt})

set(MLSDEFORM_WEB_TESTS test_stages test_stages_ring test_deformer test_arap)
foreach(name ${MLSDEFORM_WEB_TESTS})
  add_executable(web_${name} ${_src}/${name}.cpp)
  target_link_libraries(web_${name} PRIVATE mlsdeform::mlsdeform mlsdeform_web_test_support mlsdeform_web_catch_main
                                            mlsdeform_warnings)
  target_include_directories(web_${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_compile_options(web_${name} PRIVATE ${_test_opt})
  target_compile_definitions(web_${name} PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  target_link_options(web_${name} PRIVATE -sNODERAWFS=1 -sALLOW_MEMORY_GROWTH=1 -sENVIRONMENT=node)
  set_target_properties(web_${name} PROPERTIES SUFFIX ".js")
  add_test(NAME web:${name} COMMAND node --no-experimental-fetch $<TARGET_FILE:web_${name}>)
  set_tests_properties(web:${name} PROPERTIES LABELS web TIMEOUT 900)
endforeach()
foreach(name test_stages test_stages_ring)
  target_link_libraries(web_${name} PRIVATE mlsdeform_web_stage_entries)
endforeach()
