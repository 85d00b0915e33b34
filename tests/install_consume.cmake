# Install-and-consume test: `cmake --install` this build into a fresh prefix, then
# configure, build and run tests/consumer, a separate project that only does find_package(mlsdeform) and
# links mlsdeform::mlsdeform.
#
# This file has two roles. Included from tests/CMakeLists.txt, it adds the CTest test `install_consume`.
# Run with `cmake -P` (that is what the test does), it performs the steps. The consumer is built with the
# same compiler, generator and build type; in a sanitizer build (MLSDEFORM_SANITIZE) it gets the same
# -fsanitize flags, which the installed static library needs at link time, so the test runs in both the
# normal and the sanitizer suite of tools/dev.sh.

if(NOT CMAKE_SCRIPT_MODE_FILE)
  set(_ic_flags "")
  if(MLSDEFORM_SANITIZE)
    set(_ic_flags "-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer")
  endif()
  add_test(NAME install_consume
    COMMAND ${CMAKE_COMMAND}
      -DMLSDEFORM_BINARY_DIR=${PROJECT_BINARY_DIR}
      -DCONSUMER_SOURCE_DIR=${CMAKE_CURRENT_SOURCE_DIR}/consumer
      -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/install_consume
      -DCONSUMER_GENERATOR=${CMAKE_GENERATOR}
      -DCONSUMER_CXX_COMPILER=${CMAKE_CXX_COMPILER}
      "-DCONSUMER_CXX_FLAGS=${_ic_flags}"
      -DCONSUMER_BUILD_TYPE=$<CONFIG>
      -P ${CMAKE_CURRENT_LIST_FILE})
  # A clean configure and build of a small project with all dependencies takes ~30 s on a 2-core machine.
  set_tests_properties(install_consume PROPERTIES TIMEOUT 600 LABELS install RUN_SERIAL TRUE)
  return()
endif()

# ---- script mode ----
function(_ic_run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "install_consume: ${what} failed (${rc})\n${out}\n${err}")
  endif()
  message(STATUS "install_consume: ${what}: ok")
  set(_ic_last_output "${out}" PARENT_SCOPE)
endfunction()

set(_prefix ${WORK_DIR}/prefix)
set(_build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${WORK_DIR})  # a fresh prefix every run
file(MAKE_DIRECTORY ${WORK_DIR})

if(NOT CONSUMER_BUILD_TYPE)
  set(CONSUMER_BUILD_TYPE Release)
endif()
_ic_run("cmake --install into ${_prefix}"
  ${CMAKE_COMMAND} --install ${MLSDEFORM_BINARY_DIR} --prefix ${_prefix} --config ${CONSUMER_BUILD_TYPE})
if(NOT EXISTS ${_prefix}/include/mlsdeform/mlsdeform.hpp)
  message(FATAL_ERROR "install_consume: the install did not put the headers in ${_prefix}/include")
endif()
# The command-line program comes along (when the tools are built) and answers --version.
if(EXISTS ${MLSDEFORM_BINARY_DIR}/tools/mlsdeform)
  if(NOT EXISTS ${_prefix}/bin/mlsdeform)
    message(FATAL_ERROR "install_consume: the install did not put the program in ${_prefix}/bin")
  endif()
  _ic_run("installed mlsdeform --version" ${_prefix}/bin/mlsdeform --version)
  if(NOT _ic_last_output MATCHES "^[0-9]+\\.[0-9]+\\.[0-9]+")
    message(FATAL_ERROR "install_consume: mlsdeform --version printed '${_ic_last_output}'")
  endif()
endif()

# Only the fresh prefix may provide mlsdeform: no package registries, and the consumer checks mlsdeform_DIR.
_ic_run("configure the consumer"
  ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${_build} -G ${CONSUMER_GENERATOR}
    -DCMAKE_BUILD_TYPE=${CONSUMER_BUILD_TYPE}
    -DCMAKE_CXX_COMPILER=${CONSUMER_CXX_COMPILER}
    "-DCMAKE_CXX_FLAGS=${CONSUMER_CXX_FLAGS}"
    -DCMAKE_PREFIX_PATH=${_prefix}
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
    -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF
    -DMLSDEFORM_EXPECTED_PREFIX=${_prefix})
_ic_run("build the consumer" ${CMAKE_COMMAND} --build ${_build} --config ${CONSUMER_BUILD_TYPE})

find_program(_consumer consumer PATHS ${_build} ${_build}/${CONSUMER_BUILD_TYPE} NO_DEFAULT_PATH)
if(NOT _consumer)
  message(FATAL_ERROR "install_consume: no consumer executable in ${_build}")
endif()
_ic_run("run the consumer" ${_consumer})
message(STATUS "${_ic_last_output}")
if(NOT _ic_last_output MATCHES "consumer: ok")
  message(FATAL_ERROR "install_consume: the consumer did not report success")
endif()
