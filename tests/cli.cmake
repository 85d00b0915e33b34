# Tests of the mlsdeform command-line tool (tools/cli/, tests/cli/) and the libFuzzer target for its
# handles-file reader (tests/fuzz/). Included by tests/CMakeLists.txt; only when the tools are built.
if(NOT MLSDEFORM_BUILD_TOOLS)
  return()
endif()

# Unit tests against the tool's library (mesh I/O, handles file), and end-to-end tests that run the program
# (every subcommand, every bad input: exit code, message, no output left). mlsdeform_cli and mlsdeform are
# defined in tools/mlsdeform.cmake, which CMake reads after this file: target names resolve at generation.
file(GLOB _cli_tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/cli/test_*.cpp)
foreach(src ${_cli_tests})
  get_filename_component(name ${src} NAME_WE)
  add_executable(${name} ${src})
  target_link_libraries(${name} PRIVATE mlsdeform_cli Catch2::Catch2WithMain mlsdeform_warnings)
  target_include_directories(${name} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/cli)
  target_compile_definitions(${name} PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                                             MLSDEFORM_CLI="$<TARGET_FILE:mlsdeform>")
  add_dependencies(${name} mlsdeform)
  catch_discover_tests(${name} TEST_PREFIX "${name}:" PROPERTIES TIMEOUT 600 LABELS cli)
endforeach()

# The fuzz target: clang++ -fsanitize=fuzzer (libFuzzer from Debian's libclang-rt-14-dev), built by a plain
# custom command because the main build uses g++. Not in the sanitizer build: it is its own ASan/UBSan build,
# and its test is labelled no_sanitizer.
set(_fuzz_dir ${CMAKE_CURRENT_SOURCE_DIR}/fuzz)
if(NOT MLSDEFORM_SANITIZE)
  find_program(MLSDEFORM_CLANGXX NAMES clang++ clang++-14 DOC "clang++ for the libFuzzer target")
  set(_fuzz_ok FALSE)
  if(MLSDEFORM_CLANGXX)
    # Does this clang have libFuzzer? (Debian: libclang-rt-14-dev.) Checked once, at configure time.
    set(_probe ${CMAKE_CURRENT_BINARY_DIR}/fuzz_probe.cpp)
    file(WRITE ${_probe} "#include <cstddef>\n#include <cstdint>\nextern \"C\" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }\n")
    execute_process(COMMAND ${MLSDEFORM_CLANGXX} -fsanitize=fuzzer ${_probe} -o ${CMAKE_CURRENT_BINARY_DIR}/fuzz_probe
                    RESULT_VARIABLE _probe_rc OUTPUT_QUIET ERROR_QUIET)
    if(_probe_rc EQUAL 0)
      set(_fuzz_ok TRUE)
    else()
      set(_fuzz_why "${MLSDEFORM_CLANGXX} cannot link -fsanitize=fuzzer (Debian: apt-get install libclang-rt-14-dev)")
    endif()
  else()
    set(_fuzz_why "clang++ not found (Debian: apt-get install clang libclang-rt-14-dev)")
  endif()

  if(_fuzz_ok)
    find_package(nlohmann_json 3 CONFIG REQUIRED)
    get_target_property(_eigen_inc Eigen3::Eigen INTERFACE_INCLUDE_DIRECTORIES)
    get_target_property(_json_inc nlohmann_json::nlohmann_json INTERFACE_INCLUDE_DIRECTORIES)
    set(_fuzz_sources ${_fuzz_dir}/fuzz_handles.cpp ${PROJECT_SOURCE_DIR}/tools/cli/handles_file.cpp
                      ${PROJECT_SOURCE_DIR}/tools/cli/file_io.cpp)
    set(_fuzz_includes)
    foreach(d ${PROJECT_SOURCE_DIR}/tools/cli ${PROJECT_SOURCE_DIR}/core/include ${_eigen_inc} ${_json_inc})
      list(APPEND _fuzz_includes -I${d})
    endforeach()
    list(REMOVE_DUPLICATES _fuzz_includes)
    set(_fuzz_bin ${CMAKE_CURRENT_BINARY_DIR}/fuzz_handles)
    add_custom_command(
      OUTPUT ${_fuzz_bin}
      COMMAND ${MLSDEFORM_CLANGXX} -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
              ${_fuzz_includes} ${_fuzz_sources} -lz -o ${_fuzz_bin}
      DEPENDS ${_fuzz_sources} ${PROJECT_SOURCE_DIR}/tools/cli/handles_file.hpp ${PROJECT_SOURCE_DIR}/tools/cli/error.hpp
              ${PROJECT_SOURCE_DIR}/tools/cli/file_io.hpp
      COMMENT "Building the libFuzzer target fuzz_handles with ${MLSDEFORM_CLANGXX}"
      VERBATIM)
    add_custom_target(fuzz_handles ALL DEPENDS ${_fuzz_bin})
    # A bounded run: the seed corpus, then 20000 generated inputs (a few seconds). New inputs go to a scratch
    # folder in the build tree, never into the source tree's corpus.
    add_test(NAME cli:fuzz_handles
             COMMAND ${CMAKE_COMMAND} -E env ASAN_OPTIONS=detect_leaks=1
                     ${CMAKE_COMMAND} -DFUZZER=${_fuzz_bin} -DSCRATCH=${CMAKE_CURRENT_BINARY_DIR}/fuzz_corpus
                     -DSEEDS=${_fuzz_dir}/corpus -DDICT=${_fuzz_dir}/handles.dict -P ${_fuzz_dir}/run_fuzz.cmake)
    set_tests_properties(cli:fuzz_handles PROPERTIES LABELS "cli;no_sanitizer" TIMEOUT 300)
  else()
    message(STATUS "mlsdeform: fuzz target skipped: ${_fuzz_why}")
    add_test(NAME cli:fuzz_handles COMMAND ${CMAKE_COMMAND} -E echo "fuzz target skipped: ${_fuzz_why}")
    set_tests_properties(cli:fuzz_handles PROPERTIES LABELS "cli;no_sanitizer" SKIP_REGULAR_EXPRESSION "skipped")
  endif()
endif()
