# accuracy_report: writes docs/accuracy.md from the accuracy suite's case families.
# It links the shared test helpers (tests/support: no Catch2), which the top level builds whenever the tools are.
add_executable(accuracy_report ${CMAKE_CURRENT_SOURCE_DIR}/accuracy_report.cpp)
target_link_libraries(accuracy_report PRIVATE mlsdeform::mlsdeform mlsdeform_test_support mlsdeform_warnings)
target_compile_definitions(accuracy_report PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
find_package(Threads REQUIRED)
target_link_libraries(accuracy_report PRIVATE Threads::Threads)
