# The site (build-web/site/, served by tools/dev.sh web --serve): the page, the module, three.js and Spark from
# web/node_modules (tools/install_deps.sh web: npm ci), and the bundled human with its licence.
set(_three ${PROJECT_SOURCE_DIR}/web/node_modules/three)
if(NOT EXISTS ${_three}/build/three.module.js)
  message(FATAL_ERROR "web/node_modules/three is missing: run tools/install_deps.sh web (npm ci in web/)")
endif()
set(_spark ${PROJECT_SOURCE_DIR}/web/node_modules/@sparkjsdev/spark)
if(NOT EXISTS ${_spark}/dist/spark.module.min.js)
  message(FATAL_ERROR "web/node_modules/@sparkjsdev/spark is missing: run tools/install_deps.sh web (npm ci in web/)")
endif()
set(_site ${CMAKE_BINARY_DIR}/site)
set(_page index.html src/page.js src/interaction.js src/bench.js src/formats.js src/io.js src/mlsdeform.js src/mlsdeform.d.ts
          src/page_splats.js src/splat_view.js src/splat_scene.js src/bench_splats.js)
set(_site_inputs "")
set(_copies "")
foreach(f ${_page})
  get_filename_component(_name ${f} NAME)
  list(APPEND _copies COMMAND ${CMAKE_COMMAND} -E copy ${PROJECT_SOURCE_DIR}/web/${f} ${_site}/${_name})
  list(APPEND _site_inputs ${PROJECT_SOURCE_DIR}/web/${f})
endforeach()
foreach(f build/three.module.js build/three.core.js LICENSE)
  get_filename_component(_name ${f} NAME)
  list(APPEND _copies COMMAND ${CMAKE_COMMAND} -E copy ${_three}/${f} ${_site}/vendor/${_name})
endforeach()
foreach(f controls/OrbitControls controls/TransformControls postprocessing/Pass)
  list(APPEND _copies COMMAND ${CMAKE_COMMAND} -E copy ${_three}/examples/jsm/${f}.js ${_site}/vendor/addons/${f}.js)
endforeach()
# Spark (splat scenes: web/src/splat_view.js), one ES module with its sorting worker and WebAssembly inside.
list(APPEND _copies COMMAND ${CMAKE_COMMAND} -E copy ${_spark}/dist/spark.module.min.js ${_site}/vendor/spark.module.js
     COMMAND ${CMAKE_COMMAND} -E copy ${_spark}/LICENSE ${_site}/vendor/LICENSE.spark)
foreach(f human_man.obj human_bend.json LICENSES.txt)
  list(APPEND _copies COMMAND ${CMAKE_COMMAND} -E copy ${PROJECT_SOURCE_DIR}/data/${f} ${_site}/${f})
  list(APPEND _site_inputs ${PROJECT_SOURCE_DIR}/data/${f})
endforeach()
add_custom_command(OUTPUT ${_site}/index.html
  COMMAND ${CMAKE_COMMAND} -E make_directory ${_site}/vendor/addons/controls ${_site}/vendor/addons/postprocessing
  ${_copies}
  COMMAND ${CMAKE_COMMAND} -E copy $<TARGET_FILE:mlsdeform_wasm> ${_site}/mlsdeform_wasm.mjs
  COMMAND ${CMAKE_COMMAND} -E copy $<TARGET_FILE_DIR:mlsdeform_wasm>/mlsdeform_wasm.wasm ${_site}/mlsdeform_wasm.wasm
  DEPENDS ${_site_inputs} mlsdeform_wasm
  COMMENT "The page: build-web/site/")
add_custom_target(mlsdeform_site ALL DEPENDS ${_site}/index.html)
