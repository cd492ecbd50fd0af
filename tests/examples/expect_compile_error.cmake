# cmake -P driver for the compile-fail tests: compiles one source and checks the diagnostics.
#   -DCOMPILER=<c++> -DSOURCE=<file.cpp> -DFLAGS=<flag|flag|...>
#   -DERRORS=<n>     exactly n lines "error: ..."; 0 means it must compile with no output at all
#   -DEXPECT=<regex> every error line must match it
# Counting the errors, not only finding the message, is the point: a missing kernel must give
# its one clear message and no cascade of template errors after it.
cmake_minimum_required(VERSION 3.25)

string(REPLACE "|" ";" flags "${FLAGS}")
execute_process(COMMAND "${COMPILER}" ${flags} "${SOURCE}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
# Semicolons would split the list of matches: read them as commas (write '.' for ';' in EXPECT).
string(REPLACE ";" "," flat "${out}")
string(REGEX MATCHALL "[^\n]*error:[^\n]*" errors "${flat}")
list(LENGTH errors count)

if(ERRORS EQUAL 0)
  if(NOT rc EQUAL 0 OR NOT out STREQUAL "")
    message(FATAL_ERROR "expected a clean compile, got (exit ${rc}):\n${out}")
  endif()
  message(STATUS "compiled cleanly")
  return()
endif()
if(rc EQUAL 0)
  message(FATAL_ERROR "expected the compile to fail, but it succeeded:\n${out}")
endif()
if(NOT count EQUAL ERRORS)
  message(FATAL_ERROR "expected ${ERRORS} error(s), got ${count}:\n${out}")
endif()
foreach(line IN LISTS errors)
  if(NOT line MATCHES "${EXPECT}")
    message(FATAL_ERROR "this error does not match \"${EXPECT}\":\n  ${line}\nfull output:\n${out}")
  endif()
endforeach()
message(STATUS "failed as expected with ${count} error(s):\n${out}")
