# The `web` label: the library's tests compiled to WebAssembly (build-web/, tools/dev.sh web, which
# tools/dev.sh test runs first) under Node, and the page's tests in headless Chromium (web/tests/). Each
# is reported skipped where emscripten (or Chromium) is not installed.
set(MLSDEFORM_WEB_BUILD_DIR ${PROJECT_SOURCE_DIR}/build-web CACHE PATH "The WebAssembly build tree (tools/dev.sh web)")
foreach(name test_stages test_deformer test_arap)
  add_test(NAME web:${name} COMMAND bash ${PROJECT_SOURCE_DIR}/web/tests/run_node_test.sh
                                    ${MLSDEFORM_WEB_BUILD_DIR}/web/web_${name}.js)
  set_tests_properties(web:${name} PROPERTIES LABELS "web;no_sanitizer" SKIP_RETURN_CODE 77 TIMEOUT 900)
endforeach()
