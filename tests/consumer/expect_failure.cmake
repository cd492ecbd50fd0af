# cmake -P driver for the bad-input tests: runs one configure or one build that must fail, and
# checks that the output names the model and the problem, and that no output was left behind.
#   -DSTEP=configure -DSOURCE_DIR=<project> -DBINARY_DIR=<fresh dir> [-DCASE=<case>]
#   -DSTEP=build -DBINARY_DIR=<configured dir> -DTARGET=<model target>
#   -DEXPECT=<regex> [-DALSO_EXPECT=<regex>]   both must match the output
#   [-DMODEL=<name>]   after the failed build, <BINARY_DIR>/eomgen/<name>/<name>.hpp and .cpp
#                      must not exist
#   [-DGENERATOR=...] [-DCXX_COMPILER=...] [-DEOMGEN_PREFIX=...] [-DEOMGEN_CMAKE_FILE=...]
cmake_minimum_required(VERSION 3.25)

if(STEP STREQUAL "configure")
  file(REMOVE_RECURSE "${BINARY_DIR}")
  set(command "${CMAKE_COMMAND}" -S "${SOURCE_DIR}" -B "${BINARY_DIR}" -DCMAKE_BUILD_TYPE=Debug)
  foreach(var GENERATOR CXX_COMPILER EOMGEN_PREFIX EOMGEN_CMAKE_FILE CASE)
    if(${var})
      list(APPEND command "-D${var}=${${var}}")
    endif()
  endforeach()
  if(GENERATOR)
    list(APPEND command -G "${GENERATOR}")
  endif()
elseif(STEP STREQUAL "build")
  set(command "${CMAKE_COMMAND}" --build "${BINARY_DIR}" --target "${TARGET}")
else()
  message(FATAL_ERROR "STEP must be configure or build")
endif()

execute_process(COMMAND ${command} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
string(REPLACE ";" " " shown "${command}")
if(rc EQUAL 0)
  message(FATAL_ERROR "expected a failure, but this succeeded:\n  ${shown}\n${out}")
endif()
# CMake and compilers wrap long messages: match with every whitespace run read as one space.
string(REGEX REPLACE "[ \t\r\n]+" " " flat "${out}")
foreach(regex IN ITEMS "${EXPECT}" "${ALSO_EXPECT}")
  if(NOT regex STREQUAL "" AND NOT flat MATCHES "${regex}")
    message(FATAL_ERROR "the output of\n  ${shown}\ndoes not match \"${regex}\":\n${out}")
  endif()
endforeach()
if(MODEL)
  set(dir "${BINARY_DIR}/eomgen/${MODEL}")
  foreach(file "${dir}/${MODEL}.hpp" "${dir}/${MODEL}.cpp")
    if(EXISTS "${file}")
      message(FATAL_ERROR "the failed build left ${file} behind")
    endif()
  endforeach()
endif()
message(STATUS "failed as expected:\n${out}")
