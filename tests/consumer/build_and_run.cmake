# cmake -P driver for the consumer tests: optionally installs an eomgen build into a prefix, then
# configures, builds and runs a throwaway project from scratch.
#   -DSOURCE_DIR=<project> -DBINARY_DIR=<fresh build dir> -DRUN=<executable> -DEXPECT=<regex>
#   [-DEOMGEN_SOURCE_DIR=<tree>]  consumer uses add_subdirectory(<tree>)
#   [-DEOMGEN_PREFIX=<prefix>]    consumer uses find_package from <prefix>
#   [-DINSTALL_FROM=<build dir>]  only install <build dir> into EOMGEN_PREFIX (no project)
#   [-DCONFIGURE_ONLY=ON]         only configure the project
#   [-DGENERATOR=...] [-DCXX_COMPILER=...]  the same toolchain as the main build
#   [-DINCREMENTAL=ON]            builds a copy of the project, then checks that touching its
#                                 model header runs the generator again but recompiles no generated
#                                 source, and that changing the model recompiles it
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
if(INCREMENTAL)  # a copy to touch and edit (the consumer project reads ../urdf/robots/pendulum.urdf)
  set(copy "${BINARY_DIR}-src")
  file(REMOVE_RECURSE "${copy}")
  file(COPY "${SOURCE_DIR}/" DESTINATION "${copy}/consumer")
  file(COPY "${SOURCE_DIR}/../urdf/robots/pendulum.urdf" DESTINATION "${copy}/urdf/robots")
  set(SOURCE_DIR "${copy}/consumer")
endif()
set(args -S "${SOURCE_DIR}" -B "${BINARY_DIR}" -DCMAKE_BUILD_TYPE=Debug)  # Debug: compiles fastest
if(GENERATOR)
  list(APPEND args -G "${GENERATOR}")
endif()
if(CXX_COMPILER)
  list(APPEND args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
if(EOMGEN_SOURCE_DIR)
  # Without the GPU component: these projects use none, and finding nvcc and identifying it twice
  # (check_language, enable_language) took 15 s of each configure.
  list(APPEND args "-DEOMGEN_SOURCE_DIR=${EOMGEN_SOURCE_DIR}" -DEOM_CUDA=OFF)
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

if(INCREMENTAL)
  file(GLOB_RECURSE object LIST_DIRECTORIES false "${BINARY_DIR}/*/oscillator.cpp.o")
  list(LENGTH object count)
  if(NOT count EQUAL 1)
    message(FATAL_ERROR "expected one object file oscillator.cpp.o under ${BINARY_DIR}, found: ${object}")
  endif()
  file(TIMESTAMP "${object}" built "%s")
  set(model "${SOURCE_DIR}/oscillator_model.hpp")
  execute_process(COMMAND "${CMAKE_COMMAND}" -E sleep 1.2)  # time stamps have 1 s resolution here
  file(TOUCH "${model}")
  run("build after touching the model" "${CMAKE_COMMAND}" --build "${BINARY_DIR}" --parallel 2)
  if(NOT output MATCHES "Generating the kernels of consumer::Oscillator<8>")
    message(FATAL_ERROR "touching ${model} did not run the generator again:\n${output}")
  endif()
  file(TIMESTAMP "${object}" after_touch "%s")
  if(NOT after_touch STREQUAL built)
    message(FATAL_ERROR "touching ${model} recompiled ${object} although the generated code is "
                        "unchanged:\n${output}")
  endif()
  file(READ "${model}" text)
  string(REPLACE "0.5 * p[1]" "0.25 * p[1]" changed "${text}")
  if(changed STREQUAL text)
    message(FATAL_ERROR "${model}: the potential energy's text to change was not found")
  endif()
  execute_process(COMMAND "${CMAKE_COMMAND}" -E sleep 1.2)
  file(WRITE "${model}" "${changed}")
  run("build after changing the model" "${CMAKE_COMMAND}" --build "${BINARY_DIR}" --parallel 2)
  file(TIMESTAMP "${object}" after_change "%s")
  if(NOT after_change GREATER after_touch)
    message(FATAL_ERROR "changing the potential energy in ${model} did not recompile ${object}")
  endif()
  message(STATUS "incremental: a touched model header regenerated without recompiling; a changed one recompiled")
endif()
