# The per-ISA kernel objects share no weak symbol with each other or with the baseline code.
add_test(NAME dispatch:no_shared_weak_symbols
         COMMAND ${CMAKE_COMMAND} -DARCHIVE=$<TARGET_FILE:mlsdeform_lib> -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_weak_symbols.cmake)
