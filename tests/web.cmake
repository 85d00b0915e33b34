# The `web` label: the library's tests compiled to WebAssembly (build-web/, tools/dev.sh web, which
# tools/dev.sh test runs first) under Node, and the page's tests in headless Chromium (web/tests/). Each
# is reported skipped where emscripten (or Chromium) is not installed.
set(MLSDEFORM_WEB_BUILD_DIR ${PROJECT_SOURCE_DIR}/build-web CACHE PATH "The WebAssembly build tree (tools/dev.sh web)")
foreach(name test_stages test_stages_ring test_deformer test_arap)
  add_test(NAME web:${name} COMMAND bash ${PROJECT_SOURCE_DIR}/web/tests/run_node_test.sh
                                    ${MLSDEFORM_WEB_BUILD_DIR}/web/web_${name}.js)
  set_tests_properties(web:${name} PROPERTIES LABELS "web;no_sanitizer" SKIP_RETURN_CODE 77 TIMEOUT 900)
endforeach()
# The page (build-web/site/) in headless Chromium: the human bending opened by URL against `mlsdeform deform`,
# a click and a drag, a malformed file (the program's message), a screenshot that shows the mesh, the program's
# OFF, PLY and .gz outputs read by the page; a splat scene posed (its PLY the program's, byte for byte; its SPZ
# within the format's bounds), drawn by Spark, and hostile splat files. (`compare`, `formats` and `splat_pose`
# need the program; `interact` and `malformed` use it: not in the builds without tools.)
set(_checks interact malformed screenshot splat_screenshot splat_hostile)
if(MLSDEFORM_BUILD_TOOLS)
  list(APPEND _checks compare formats splat_pose)
endif()
foreach(check ${_checks})
  add_test(NAME web:page_${check} COMMAND bash ${PROJECT_SOURCE_DIR}/web/tests/run_browser_test.sh
                                          ${MLSDEFORM_WEB_BUILD_DIR}/site ${check} $<$<BOOL:${MLSDEFORM_BUILD_TOOLS}>:$<TARGET_FILE:mlsdeform>>)
  set_tests_properties(web:page_${check} PROPERTIES LABELS "web;no_sanitizer" SKIP_RETURN_CODE 77 TIMEOUT 300
                                                    RESOURCE_LOCK chromium)
endforeach()
# The JavaScript API under Node: views, no per-frame allocation, errors, delete().
add_test(NAME web:api COMMAND bash ${PROJECT_SOURCE_DIR}/web/tests/run_node_test.sh ${PROJECT_SOURCE_DIR}/web/tests/api.mjs
                              ${MLSDEFORM_WEB_BUILD_DIR}/site)
set_tests_properties(web:api PROPERTIES LABELS "web;no_sanitizer" SKIP_RETURN_CODE 77 TIMEOUT 300)
# The JavaScript example of docs/web.md, as written there.
add_test(NAME web:doc_example COMMAND bash ${PROJECT_SOURCE_DIR}/web/tests/run_doc_example.sh ${MLSDEFORM_WEB_BUILD_DIR}/site)
set_tests_properties(web:doc_example PROPERTIES LABELS "web;no_sanitizer" SKIP_RETURN_CODE 77 TIMEOUT 300)
