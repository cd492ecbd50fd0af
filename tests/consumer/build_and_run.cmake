# cmake -P driver for the consumer tests: optionally installs an eomgen build into a prefix, then
# configures, builds and runs a throwaway project from scratch.
#   -DSOURCE_DIR=<project> -DBINARY_DIR=<fresh build dir> -DRUN=<executable> -DEXPECT=<regex>
#   [-DEOMGEN_SOURCE_DIR=<tree>]  consumer uses add_subdirectory(<tree>)
#   [-DEOMGEN_PREFIX=<prefix>]    consumer uses find_package from <prefix>
#   [-DINSTALL_FROM=<build dir>]  only install <build dir> into EOMGEN_PREFIX (no project)
#   [-DCONFIGURE_ONLY=ON]         only configure the project
#   [-DGENERATOR=...] [-DCXX_COMPILER=...]  the same toolchain as the main build
cmake_minimum_required(VERSION 3.25)

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}")
  endif()
  set(output "${out}" PARENT_SCOPE)
endfunction()

if(INSTALL_FROM)
  file(REMOVE_RECURSE "${EOMGEN_PREFIX}")
  run("cmake --install ${INSTALL_FROM}" "${CMAKE_COMMAND}" --install "${INSTALL_FROM}"
      --prefix "${EOMGEN_PREFIX}")
  message(STATUS "installed ${INSTALL_FROM} into ${EOMGEN_PREFIX}")
  return()
endif()

file(REMOVE_RECURSE "${BINARY_DIR}")
set(args -S "${SOURCE_DIR}" -B "${BINARY_DIR}" -DCMAKE_BUILD_TYPE=Debug)  # Debug: compiles fastest
if(GENERATOR)
  list(APPEND args -G "${GENERATOR}")
endif()
if(CXX_COMPILER)
  list(APPEND args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
if(EOMGEN_SOURCE_DIR)
  list(APPEND args "-DEOMGEN_SOURCE_DIR=${EOMGEN_SOURCE_DIR}")
endif()
if(EOMGEN_PREFIX)
  list(APPEND args "-DCMAKE_PREFIX_PATH=${EOMGEN_PREFIX}")
endif()

run("configure" "${CMAKE_COMMAND}" ${args})
if(CONFIGURE_ONLY)
  return()
endif()
run("build" "${CMAKE_COMMAND}" --build "${BINARY_DIR}" --parallel 2)
run("${RUN}" "${BINARY_DIR}/${RUN}")
if(NOT output MATCHES "${EXPECT}")
  message(FATAL_ERROR "${RUN} printed\n${output}\nexpected a match for: ${EXPECT}")
endif()
message(STATUS "${RUN}: ${output}")
