# Runs COMMAND (a list), prints its output, and fails unless it exits 0 and its output contains EXPECT.
# Usage: cmake "-DCOMMAND=prog;arg;..." "-DEXPECT=text" -P run_expect.cmake
execute_process(COMMAND ${COMMAND} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "exit status ${rc}: ${COMMAND}")
endif()
string(FIND "${out}" "${EXPECT}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "the output does not contain '${EXPECT}'")
endif()
