# The Python layout (black) and lint (flake8) checks: every Python file of the tree as pyproject.toml and
# .flake8 say. Skipped, with a line saying which tool is missing, where Debian's black or flake8 is not
# installed (tools/install_deps.sh installs both); `tools/dev.sh format` rewrites the Python too.
foreach(_check format lint)
  add_test(NAME python_${_check} COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_python_style.sh ${_check}
                                         ${PROJECT_SOURCE_DIR})
  set_tests_properties(python_${_check} PROPERTIES LABELS "no_sanitizer" SKIP_RETURN_CODE 77 TIMEOUT 300)
endforeach()
