# The stage test's entries (tests/stages/), built beside the library, not in it: the scalar table with the
# baseline flags, one table per ISA compiled as that ISA's kernels are (mlsdeform_isa_object,
# kernels/CMakeLists.txt), all in one static library linked into the stage tests (test_stages, test_stages_ring). dispatch.cmake checks it with
# the library for weak symbols shared across instruction sets.
set(_stage_objects "")
foreach(isa ${MLSDEFORM_ISAS})
  mlsdeform_isa_object(mlsdeform_stage_entries_${isa} ${isa} ${CMAKE_CURRENT_SOURCE_DIR}/stages/entries_${isa}.cpp)
  list(APPEND _stage_objects $<TARGET_OBJECTS:mlsdeform_stage_entries_${isa}>)
endforeach()
add_library(mlsdeform_stage_entries STATIC ${CMAKE_CURRENT_SOURCE_DIR}/stages/scalar_entries.cpp ${_stage_objects})
target_include_directories(mlsdeform_stage_entries PRIVATE ${PROJECT_SOURCE_DIR})
target_link_libraries(mlsdeform_stage_entries PRIVATE mlsdeform::mlsdeform mlsdeform_warnings)
foreach(name test_stages test_stages_ring)
  target_link_libraries(${name} PRIVATE mlsdeform_stage_entries)
endforeach()
