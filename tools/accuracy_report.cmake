# accuracy_report: writes docs/accuracy.md from the accuracy suite's case families.
# It compiles the shared test helpers' sources itself (they need only Eigen and the library, not Catch2),
# so it builds whether or not the tests are enabled.
add_executable(accuracy_report ${CMAKE_CURRENT_SOURCE_DIR}/accuracy_report.cpp
                               ${PROJECT_SOURCE_DIR}/tests/support/rotation_cases.cpp)
target_include_directories(accuracy_report PRIVATE ${PROJECT_SOURCE_DIR}/tests/support)
target_link_libraries(accuracy_report PRIVATE mlsdeform::mlsdeform mlsdeform_warnings)
target_compile_definitions(accuracy_report PRIVATE MLSDEFORM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
find_package(Threads REQUIRED)
target_link_libraries(accuracy_report PRIVATE Threads::Threads)
