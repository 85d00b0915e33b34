# The per-ISA objects (the library's kernels, and the stage test's entries linked beside it) share no weak
# symbol with an object of another instruction set or with the baseline code.
add_test(NAME dispatch:no_shared_weak_symbols
         COMMAND ${CMAKE_COMMAND} -DARCHIVE=$<TARGET_FILE:mlsdeform_lib>
                 -DEXTRA_ARCHIVE=$<TARGET_FILE:mlsdeform_stage_entries>
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_weak_symbols.cmake)
