# The mlsdeform command-line tool (tools/cli/): `deform`, `demo` and `figures`, a command layer (options,
# messages, progress) over the files library (core/files/: every reader, writer and attribute rule). Its
# dependencies (CLI11, and the files library's nlohmann-json and zlib) are linked to the tool's own targets only,
# never to the library, so the installed package and its consumers never see them.
find_package(CLI11 2 CONFIG REQUIRED)          # CLI11::CLI11 (libcli11-dev)
find_package(nlohmann_json 3 CONFIG REQUIRED)  # the figures' specifications (render.cpp)

set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)

# Everything but main(): linked by the program and by the CLI tests (tests/cli.cmake). CLI11 is compiled into
# one translation unit (main.cpp): it is slow to compile.
add_library(mlsdeform_cli STATIC
  ${_cli}/render.cpp
  ${_cli}/primitives.cpp
  ${_cli}/scenes.cpp
  ${_cli}/scene_run.cpp
  ${_cli}/figures/layout.cpp
  ${_cli}/figures/centroids.cpp
  ${_cli}/figures/figures.cpp
  ${_cli}/figures/measures.cpp
  ${_cli}/cmd_deform.cpp
  ${_cli}/cmd_demo.cpp
  ${_cli}/cmd_figures.cpp)
target_include_directories(mlsdeform_cli PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(mlsdeform_cli
  PUBLIC mlsdeform::files mlsdeform::mlsdeform
  PRIVATE nlohmann_json::nlohmann_json mlsdeform_warnings)
# Where the program finds its bundled data, the shared meshes (fig. 2's fish; optional) and the figure script
# when run from the build tree (each can be overridden at run time: MLSDEFORM_DATA_DIR, MLSDEFORM_MESHES,
# MLSDEFORM_FIGURES_SCRIPT).
target_compile_definitions(mlsdeform_cli PRIVATE
  MLSDEFORM_DATA_DIR="${PROJECT_SOURCE_DIR}/data"
  MLSDEFORM_SHARED_MESHES="${PROJECT_SOURCE_DIR}/../shared/data/meshes"
  MLSDEFORM_FIGURES_SCRIPT="${PROJECT_SOURCE_DIR}/tools/figures.py")

add_executable(mlsdeform ${_cli}/main.cpp)
target_link_libraries(mlsdeform PRIVATE mlsdeform_cli CLI11::CLI11 mlsdeform_warnings)
set_target_properties(mlsdeform PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tools)

# `cmake --install` puts the program beside the library (bin/mlsdeform), with the licence and the bundled
# meshes' attribution under share/doc/mlsdeform.
install(TARGETS mlsdeform RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/data/LICENSES.txt
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The bundled meshes, where the installed program looks first (cmd_demo.cpp, data_dir); the Python wheel puts
# them in the same place relative to its bin/mlsdeform.
install(FILES ${PROJECT_SOURCE_DIR}/data/human_man.obj ${PROJECT_SOURCE_DIR}/data/human_bend.json
              ${PROJECT_SOURCE_DIR}/data/LICENSES.txt
        DESTINATION ${CMAKE_INSTALL_DATADIR}/mlsdeform/data)
