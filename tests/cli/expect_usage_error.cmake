# Runs PROGRAM with a bad option and checks the command-line convention of every program
# (docs/operations.md "Exit codes"): exit code 1 and "NAME: ... --no-such-option" on stderr,
# nothing on stdout. Usage: cmake -DPROGRAM=path -DNAME=dfb-x -P expect_usage_error.cmake
execute_process(COMMAND ${PROGRAM} --no-such-option RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 1)
    message(FATAL_ERROR "${NAME} --no-such-option exited ${rc}, not 1\nstdout: ${out}\nstderr: ${err}")
endif()
if(NOT err MATCHES "^${NAME}: [^\n]*--no-such-option")
    message(FATAL_ERROR "${NAME} --no-such-option: stderr does not start with '${NAME}: ...--no-such-option':\n${err}")
endif()
if(NOT out STREQUAL "")
    message(FATAL_ERROR "${NAME} --no-such-option printed on stdout:\n${out}")
endif()
message(STATUS "${NAME}: ${err}")
