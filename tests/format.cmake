# The layout check: every C++ file of the project is as .clang-format says. Formatting differs between
# clang-format versions, so the check runs with Debian 12's clang-format 14 only (tools/install_deps.sh
# installs it); `tools/dev.sh format` rewrites the tree.
find_program(MLSDEFORM_CLANG_FORMAT NAMES clang-format-14)
if(MLSDEFORM_CLANG_FORMAT)
  add_test(NAME format COMMAND ${CMAKE_COMMAND} -DCLANG_FORMAT=${MLSDEFORM_CLANG_FORMAT} -DROOT=${PROJECT_SOURCE_DIR}
                               -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_format.cmake)
  set_tests_properties(format PROPERTIES LABELS "no_sanitizer")
else()
  message(STATUS "clang-format-14 not found: no format check")
endif()
