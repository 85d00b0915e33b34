# Tests of the files library (core/files/) and the mlsdeform command-line tool (tools/cli/) in tests/cli/, and
# the libFuzzer targets for the handles-file and mesh readers (tests/fuzz/). Included by tests/CMakeLists.txt;
# only when the tools are built.
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
  # A test that includes none of the program's headers is a test of the files library on its own.
  file(READ ${src} _text)
  if(_text MATCHES "#include \"tools/cli/")
    target_link_libraries(${name} PRIVATE mlsdeform_cli mlsdeform_catch_main mlsdeform_warnings)
  else()
    target_link_libraries(${name} PRIVATE mlsdeform::files mlsdeform_catch_main mlsdeform_warnings)
  endif()
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_compile_definitions(${name} PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                                             MLSDEFORM_CLI="$<TARGET_FILE:mlsdeform>")
  add_dependencies(${name} mlsdeform)
  # One label per test (catch_discover_tests flattens a list): in a cross build, `cross` for CI's ARM64 stage.
  set(_label cli)
  if(CMAKE_CROSSCOMPILING AND name IN_LIST MLSDEFORM_CROSS_LABELLED)
    set(_label cross)
  endif()
  catch_discover_tests(${name} TEST_PREFIX "${name}:" PROPERTIES TIMEOUT 600 LABELS ${_label})
endforeach()
# Normals against the MLS reference's bound (tests/support); splats from its generator, against that bound.
foreach(name test_cli_normals_motion test_cli_splats)
  if(TARGET ${name})
    target_link_libraries(${name} PRIVATE mlsdeform_test_support)
  endif()
endforeach()

# The splat formats against an independent converter, splat-transform (tests/splat_judge/judge.py, docs/splats.md):
# a rigid motion through SPZ, compressed PLY and .splat within each format's derived bound, one test per SH
# degree. Skipped, saying so, where node or splat-transform is missing (tools/install_deps.sh judge).
# Debian's interpreter (numpy), not a pyenv python3 that may come first on PATH (as the top level chooses it).
if(NOT Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python3_EXECUTABLE /usr/bin/python3)
endif()
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  foreach(_degree 0 1 2 3)
    add_test(NAME cli:splat_judge_degree_${_degree}
             COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/splat_judge/judge.py
                     --mlsdeform $<TARGET_FILE:mlsdeform> --degree ${_degree})
    set_tests_properties(cli:splat_judge_degree_${_degree} PROPERTIES LABELS cli SKIP_RETURN_CODE 77 TIMEOUT 300)
  endforeach()
endif()

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
    foreach(d ${PROJECT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/core/include ${PROJECT_SOURCE_DIR}/core/files/include
              ${_eigen_inc} ${_json_inc})
      list(APPEND _fuzz_includes -I${d})
    endforeach()
    list(REMOVE_DUPLICATES _fuzz_includes)
    set(_cli_dir ${PROJECT_SOURCE_DIR}/core/files)
    file(GLOB_RECURSE _cli_headers ${_cli_dir}/*.hpp)
    # SPZ version 4 (zstd) as the program reads it, where the build has zstd (core/files/CMakeLists.txt).
    set(_fuzz_zstd)
    find_path(MLSDEFORM_ZSTD_INCLUDE_DIR zstd.h)
    find_library(MLSDEFORM_ZSTD_LIBRARY zstd)
    if(MLSDEFORM_ZSTD_INCLUDE_DIR AND MLSDEFORM_ZSTD_LIBRARY)
      set(_fuzz_zstd -DMLSDEFORM_HAVE_ZSTD=1 -I${MLSDEFORM_ZSTD_INCLUDE_DIR} ${MLSDEFORM_ZSTD_LIBRARY})
    endif()
    # mlsdeform_fuzz_binary(NAME SOURCES...): builds NAME from the sources.
    function(mlsdeform_fuzz_binary name)
      set(bin ${CMAKE_CURRENT_BINARY_DIR}/${name})
      add_custom_command(
        OUTPUT ${bin}
        COMMAND ${MLSDEFORM_CLANGXX} -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
                ${_fuzz_includes} ${ARGN} -lz ${_fuzz_zstd} -o ${bin}
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
                     ${_cli_dir}/formats/off_write.cpp ${_cli_dir}/formats/ply_write.cpp ${_cli_dir}/formats/npy_write.cpp
                     ${_cli_dir}/splat_io.cpp ${_cli_dir}/formats/splat_common.cpp ${_cli_dir}/formats/spz.cpp
                     ${_cli_dir}/formats/compressed_ply.cpp ${_cli_dir}/formats/splat_file.cpp)
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
    # The splat formats (SPZ, .splat, compressed PLY), from seeds splat-transform wrote.
    foreach(fmt spz splat compressed.ply)
      string(REPLACE "." "_" _name ${fmt})
      mlsdeform_fuzz_test(fuzz_mesh_${_name} fuzz_mesh ${_fuzz_dir}/corpus_${_name} ${_fuzz_dir}/splats.dict 50000 8192
                          FUZZ_MESH_FORMAT=${fmt})
    endforeach()
  else()
    message(STATUS "mlsdeform: fuzz target skipped: ${_fuzz_why}")
    foreach(name fuzz_handles fuzz_mesh_obj fuzz_mesh_off fuzz_mesh_ply fuzz_mesh_gz fuzz_mesh_spz fuzz_mesh_splat
                 fuzz_mesh_compressed_ply)
      add_test(NAME cli:${name} COMMAND ${CMAKE_COMMAND} -E echo "fuzz target skipped: ${_fuzz_why}")
      set_tests_properties(cli:${name} PROPERTIES LABELS "cli;no_sanitizer" SKIP_REGULAR_EXPRESSION "skipped")
    endforeach()
  endif()
endif()
