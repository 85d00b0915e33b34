# Runs a fuzz target for a bounded number of inputs (ctest: cli:fuzz_*).
# cmake -DFUZZER=... -DSCRATCH=... -DSEEDS=... -DDICT=... -DRUNS=... -DMAX_LEN=... -P run_fuzz.cmake
file(REMOVE_RECURSE ${SCRATCH})
file(MAKE_DIRECTORY ${SCRATCH}/artifacts)
# The first corpus folder receives new inputs: the scratch one, so the source tree's seeds stay as they are.
# A fixed seed, so that a failure in CI reproduces; longer runs with other seeds are done by hand (docs/cli.md).
execute_process(COMMAND ${FUZZER} -runs=${RUNS} -max_len=${MAX_LEN} -timeout=10 -rss_limit_mb=2048 -print_final_stats=1
                        -seed=1 -artifact_prefix=${SCRATCH}/artifacts/ -dict=${DICT} ${SCRATCH} ${SEEDS}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  file(GLOB artifacts ${SCRATCH}/artifacts/*)
  message(FATAL_ERROR "${FUZZER} failed (exit code ${rc}); inputs it kept: ${artifacts}")
endif()
