# Tests of the mlsdeform command-line tool (tools/cli/, tests/cli/) and the libFuzzer targets for its
# handles-file and mesh readers (tests/fuzz/). Included by tests/CMakeLists.txt; only when the tools are built.
if(NOT MLSDEFORM_BUILD_TOOLS)
  return()
endif()

# Unit tests against the tool's library (mesh I/O, handles file), and end-to-end tests that run the program
# (every subcommand, every bad input: exit code, message, no output left). mlsdeform_cli and mlsdeform are
# defined in tools/mlsdeform.cmake, which CMake reads after this file: target names resolve at generation.
file(GLOB _cli_tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/cli/test_*.cpp)
foreach(src ${_cli_tests})
  get_filename_component(name ${src} NAME_WE)
  if(CMAKE_CROSSCOMPILING AND NOT name IN_LIST MLSDEFORM_CROSS_TESTS)  # tests/CMakeLists.txt
    continue()
  endif()
  add_executable(${name} ${src})
  target_link_libraries(${name} PRIVATE mlsdeform_cli mlsdeform_catch_main mlsdeform_warnings)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_compile_definitions(${name} PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                                             MLSDEFORM_CLI="$<TARGET_FILE:mlsdeform>")
  add_dependencies(${name} mlsdeform)
  catch_discover_tests(${name} TEST_PREFIX "${name}:" PROPERTIES TIMEOUT 600 LABELS cli)
endforeach()
# Normals against the MLS reference's bound (tests/support); splats from its generator, against that bound.
foreach(name test_cli_normals_motion test_cli_splats)
  if(TARGET ${name})
    target_link_libraries(${name} PRIVATE mlsdeform_test_support)
  endif()
endforeach()

# The fuzz targets: clang++ -fsanitize=fuzzer (libFuzzer from Debian's libclang-rt-14-dev), built by a plain
# custom command because the main build uses g++. Not in the sanitizer build: it is its own ASan/UBSan build,
# and its test is labelled no_sanitizer.
set(_fuzz_dir ${CMAKE_CURRENT_SOURCE_DIR}/fuzz)
if(NOT MLSDEFORM_SANITIZE AND NOT CMAKE_CROSSCOMPILING)  # libFuzzer targets are the host's
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
    set(_fuzz_includes)
    foreach(d ${PROJECT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/core/include ${_eigen_inc} ${_json_inc})
      list(APPEND _fuzz_includes -I${d})
    endforeach()
    list(REMOVE_DUPLICATES _fuzz_includes)
    set(_cli_dir ${PROJECT_SOURCE_DIR}/tools/cli)
    file(GLOB_RECURSE _cli_headers ${_cli_dir}/*.hpp)
    # mlsdeform_fuzz_binary(NAME SOURCES...): builds NAME from the sources.
    function(mlsdeform_fuzz_binary name)
      set(bin ${CMAKE_CURRENT_BINARY_DIR}/${name})
      add_custom_command(
        OUTPUT ${bin}
        COMMAND ${MLSDEFORM_CLANGXX} -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
                ${_fuzz_includes} ${ARGN} -lz -o ${bin}
        DEPENDS ${ARGN} ${_cli_headers}
        COMMENT "Building the libFuzzer target ${name} with ${MLSDEFORM_CLANGXX}"
        VERBATIM)
      add_custom_target(${name} ALL DEPENDS ${bin})
    endfunction()
    # mlsdeform_fuzz_test(NAME BINARY CORPUS DICT RUNS MAX_LEN [ENV...]): the test cli:NAME, a bounded run of
    # BINARY over the seed corpus. New inputs go to a scratch folder in the build tree, never into the source
    # tree's corpus.
    function(mlsdeform_fuzz_test name binary corpus dict runs max_len)
      add_test(NAME cli:${name}
               COMMAND ${CMAKE_COMMAND} -E env ASAN_OPTIONS=detect_leaks=1 ${ARGN}
                       ${CMAKE_COMMAND} -DFUZZER=${CMAKE_CURRENT_BINARY_DIR}/${binary}
                       -DSCRATCH=${CMAKE_CURRENT_BINARY_DIR}/${name}_corpus -DSEEDS=${corpus} -DDICT=${dict}
                       -DRUNS=${runs} -DMAX_LEN=${max_len} -P ${_fuzz_dir}/run_fuzz.cmake)
      set_tests_properties(cli:${name} PROPERTIES LABELS "cli;no_sanitizer" TIMEOUT 300)
    endfunction()

    mlsdeform_fuzz_binary(fuzz_handles ${_fuzz_dir}/fuzz_handles.cpp ${_cli_dir}/handles/parse.cpp
                          ${_cli_dir}/handles/resolve.cpp ${_cli_dir}/file_read.cpp ${_cli_dir}/memory_source.cpp)
    mlsdeform_fuzz_test(fuzz_handles fuzz_handles ${_fuzz_dir}/corpus ${_fuzz_dir}/handles.dict 20000 2048)
    # The mesh readers and writers, one per format, and what they share.
    set(_cli_formats ${_cli_dir}/attributes.cpp ${_cli_dir}/attributes_ops.cpp ${_cli_dir}/formats/reader.cpp ${_cli_dir}/formats/numbers.cpp ${_cli_dir}/formats/obj_read.cpp ${_cli_dir}/formats/off_read.cpp
                     ${_cli_dir}/formats/ply_read.cpp ${_cli_dir}/formats/obj_write.cpp
                     ${_cli_dir}/formats/off_write.cpp ${_cli_dir}/formats/ply_write.cpp)
    # One target per mesh reader, and one for gzip input (FUZZ_MESH_FORMAT picks it); each round-trips what it
    # reads through the writer.
    mlsdeform_fuzz_binary(fuzz_mesh ${_fuzz_dir}/fuzz_mesh.cpp ${_cli_dir}/mesh_read.cpp ${_cli_formats}
                          ${_cli_dir}/mesh_write.cpp ${_cli_dir}/file_read.cpp ${_cli_dir}/memory_source.cpp
                          ${_cli_dir}/file_write.cpp)
    foreach(fmt obj off ply)
      mlsdeform_fuzz_test(fuzz_mesh_${fmt} fuzz_mesh ${_fuzz_dir}/corpus_${fmt} ${_fuzz_dir}/mesh.dict 100000 4096
                          FUZZ_MESH_FORMAT=${fmt})
    endforeach()
    mlsdeform_fuzz_test(fuzz_mesh_gz fuzz_mesh ${_fuzz_dir}/corpus_gz ${_fuzz_dir}/gzip.dict 100000 4096
                        FUZZ_MESH_FORMAT=gz)
  else()
    message(STATUS "mlsdeform: fuzz target skipped: ${_fuzz_why}")
    foreach(name fuzz_handles fuzz_mesh_obj fuzz_mesh_off fuzz_mesh_ply fuzz_mesh_gz)
      add_test(NAME cli:${name} COMMAND ${CMAKE_COMMAND} -E echo "fuzz target skipped: ${_fuzz_why}")
      set_tests_properties(cli:${name} PROPERTIES LABELS "cli;no_sanitizer" SKIP_REGULAR_EXPRESSION "skipped")
    endforeach()
  endif()
endif()
