# Runs a fuzz target for a bounded number of inputs (ctest: cli:fuzz_*).
# cmake -DFUZZER=... -DSCRATCH=... -DSEEDS=... -DDICT=... -DRUNS=... -DMAX_LEN=... -P run_fuzz.cmake
file(REMOVE_RECURSE ${SCRATCH})
file(MAKE_DIRECTORY ${SCRATCH})
# The first corpus folder receives new inputs: the scratch one, so the source tree's seeds stay as they are.
execute_process(COMMAND ${FUZZER} -runs=${RUNS} -max_len=${MAX_LEN} -timeout=10 -rss_limit_mb=2048 -seed=0 -print_final_stats=1
                        -dict=${DICT} ${SCRATCH} ${SEEDS}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${FUZZER} failed (exit code ${rc}); the crashing input is in the working folder (crash-*)")
endif()
