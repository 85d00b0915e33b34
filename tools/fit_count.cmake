# fit_count: batched fits as a fixed workload, to count instructions per fit under an emulator
# (tools/insn_per_fit.sh).
add_executable(fit_count ${CMAKE_CURRENT_SOURCE_DIR}/fit_count.cpp)
target_link_libraries(fit_count PRIVATE mlsdeform::mlsdeform mlsdeform_warnings)
