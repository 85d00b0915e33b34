# The layout check: every C++ file of the project is as .clang-format says. Formatting differs between
# clang-format versions, so the check runs with Debian 12's clang-format 14 only (tools/install_deps.sh
# installs it); `tools/dev.sh format` rewrites the tree. Where clang-format-14 is missing (Debian 13 has only
# clang-format 19) the test is still added, and reports itself skipped with the reason: ctest lists it among
# the tests that did not run, so a missing check is never mistaken for a passing one.
find_program(MLSDEFORM_CLANG_FORMAT NAMES clang-format-14)
if(MLSDEFORM_CLANG_FORMAT)
  add_test(NAME format COMMAND ${CMAKE_COMMAND} -DCLANG_FORMAT=${MLSDEFORM_CLANG_FORMAT} -DROOT=${PROJECT_SOURCE_DIR}
                               -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_format.cmake)
else()
  find_program(MLSDEFORM_OTHER_CLANG_FORMAT NAMES clang-format)
  set(_why "clang-format-14 not found")
  if(MLSDEFORM_OTHER_CLANG_FORMAT)
    execute_process(COMMAND ${MLSDEFORM_OTHER_CLANG_FORMAT} --version OUTPUT_VARIABLE _version
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    set(_why "${_why}; ${_version} lays out differently from the version 14 that the tree is formatted with")
  endif()
  set(_why "format skipped: ${_why} (Debian 12: apt-get install clang-format-14)")
  message(WARNING "${_why}")
  add_test(NAME format COMMAND sh -c "echo \"$1\"; exit 77" format "${_why}")
endif()
set_tests_properties(format PROPERTIES LABELS "no_sanitizer" SKIP_RETURN_CODE 77)
