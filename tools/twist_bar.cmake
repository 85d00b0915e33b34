# twist_bar: the paper's Fig. 3 (a bar twisted by successive small torsions), writes OBJ.
add_executable(twist_bar ${CMAKE_CURRENT_SOURCE_DIR}/twist_bar.cpp)
target_link_libraries(twist_bar PRIVATE mlsdeform::mlsdeform mlsdeform_warnings)
