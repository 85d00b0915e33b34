# Runs the fuzz target for a bounded number of inputs (ctest: cli:fuzz_handles).
# cmake -DFUZZER=... -DSCRATCH=... -DSEEDS=... -DDICT=... -P run_fuzz.cmake
file(REMOVE_RECURSE ${SCRATCH})
file(MAKE_DIRECTORY ${SCRATCH})
# The first corpus folder receives new inputs: the scratch one, so the source tree's seeds stay as they are.
execute_process(COMMAND ${FUZZER} -runs=20000 -max_len=2048 -timeout=10 -rss_limit_mb=2048 -seed=0 -print_final_stats=1
                        -dict=${DICT} ${SCRATCH} ${SEEDS}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fuzz_handles failed (exit code ${rc}); the crashing input is in the working folder (crash-*)")
endif()
