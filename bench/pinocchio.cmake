# eom_bench_pinocchio: the codegen peer (bench/bench_pinocchio.cpp): eomgen's kernels against
# Pinocchio and Pinocchio's CppADCodeGen output. Opt-in: only when EOM_BENCH_PINOCCHIO_PREFIX
# names an install of Pinocchio (3.x, configured with BUILD_WITH_CODEGEN_SUPPORT), CppAD and
# CppADCodeGen; nothing of them is vendored or required. bench/pinocchio.sh builds such an install
# from their sources, configures this with it, runs the benchmark and writes
# docs/benchmarks/pinocchio.md.
set(EOM_BENCH_PINOCCHIO_PREFIX "" CACHE PATH
    "Install prefix of Pinocchio + CppAD + CppADCodeGen for eom_bench_pinocchio (empty: not built)")
set(EOM_BENCH_PINOCCHIO_CHAIN 30 CACHE STRING
    "eom_bench_pinocchio's long chain: bench/robots/chain<N>.urdf (N = 2, 5, 10, 20, 30)")
if(NOT EOM_BENCH_PINOCCHIO_PREFIX)
  return()
endif()

set(prefix "${EOM_BENCH_PINOCCHIO_PREFIX}")
foreach(header pinocchio/codegen/code-generator-algo.hpp cppad/cg.hpp cppad/cppad.hpp)
  if(NOT EXISTS "${prefix}/include/${header}")
    message(FATAL_ERROR "EOM_BENCH_PINOCCHIO_PREFIX=${prefix}: ${prefix}/include/${header} is "
                        "missing; it must hold Pinocchio (with codegen support), CppAD and "
                        "CppADCodeGen (bench/pinocchio.sh builds such an install)")
  endif()
endforeach()
set(chain_urdf "${CMAKE_CURRENT_SOURCE_DIR}/robots/chain${EOM_BENCH_PINOCCHIO_CHAIN}.urdf")
if(NOT EXISTS "${chain_urdf}")
  message(FATAL_ERROR "EOM_BENCH_PINOCCHIO_CHAIN=${EOM_BENCH_PINOCCHIO_CHAIN}: no ${chain_urdf}")
endif()
find_path(EOM_QD_INCLUDE qd/dd_real.h)
find_library(EOM_QD_LIB qd)
find_package(Boost 1.74 REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_program(EOM_PINOCCHIO_CC NAMES gcc cc REQUIRED)  # compiles Pinocchio's generated C
if(NOT EOM_QD_INCLUDE OR NOT EOM_QD_LIB)
  message(FATAL_ERROR "eom_bench_pinocchio needs qd (apt-get install libqd-dev)")
endif()

# The kernels the benchmark times, twice per robot: every parameter folded, and every one free.
set(kernels mass_matrix inverse_dynamics forward_dynamics forward_dynamics_derivatives
            inverse_dynamics_derivatives)
set(urdf_panda "${PROJECT_SOURCE_DIR}/models/robots/panda.urdf")
set(urdf_ur5 "${PROJECT_SOURCE_DIR}/models/robots/ur5.urdf")
set(urdf_chain "${chain_urdf}")
# CppAD's small run-time library (its temporary files); the install's lib/ is put on the rpath.
find_library(EOM_CPPAD_LIB cppad_lib PATHS "${prefix}/lib" NO_DEFAULT_PATH REQUIRED)
# Pinocchio's CodeGen templates (bench/pinocchio_codegen.cpp) take about 10 minutes to compile:
# compiled once for both binaries, apart from their kernel libraries' flags.
add_library(eom_pinocchio_codegen STATIC EXCLUDE_FROM_ALL pinocchio_codegen.cpp)
target_include_directories(eom_pinocchio_codegen SYSTEM PUBLIC "${prefix}/include"
                           ${Boost_INCLUDE_DIRS})
target_link_libraries(eom_pinocchio_codegen PUBLIC Eigen3::Eigen "${EOM_CPPAD_LIB}" ${CMAKE_DL_LIBS})
# Pinocchio's and CppAD's headers are not -Wall -Werror clean: no eom_warnings here.
target_compile_options(eom_pinocchio_codegen PRIVATE -O3 -march=native -Wno-deprecated-declarations)
add_executable(eom_bench_pinocchio bench_pinocchio.cpp pinocchio_truth.cpp)
# qd's double-double arithmetic must not be contracted into FMAs (-march=native).
set_source_files_properties(pinocchio_truth.cpp PROPERTIES COMPILE_OPTIONS "-ffp-contract=off")
foreach(robot panda ur5 chain)
  add_eom_model(pin_${robot}_folded URDF "${urdf_${robot}}" KERNELS ${kernels} FIXED_PARAMETERS ALL)
  add_eom_model(pin_${robot}_free URDF "${urdf_${robot}}" KERNELS ${kernels})
  foreach(variant folded free)
    target_compile_options(pin_${robot}_${variant} PRIVATE -O3 -march=native)
    target_link_libraries(eom_bench_pinocchio PRIVATE pin_${robot}_${variant})
  endforeach()
endforeach()
# Romeo (example-robot-data, bundled: 37 velocities, 31 revolute joints on a free root), its two
# inconsistent arm inertias taken as published (tests/urdf/robots/published/README.md).
set(pin_romeo "${PROJECT_SOURCE_DIR}/tests/urdf/robots/published/romeo_small.urdf")
add_eom_model(pin_romeo_folded URDF "${pin_romeo}" FLOATING_BASE INERTIA_POLICY warn
              KERNELS ${kernels} FIXED_PARAMETERS ALL)
add_eom_model(pin_romeo_free URDF "${pin_romeo}" FLOATING_BASE INERTIA_POLICY warn
              KERNELS ${kernels})
foreach(variant folded free)
  target_compile_options(pin_romeo_${variant} PRIVATE -O3 -march=native)
  target_link_libraries(eom_bench_pinocchio PRIVATE pin_romeo_${variant})
endforeach()
# MuJoCo's humanoid (27 dof on a free base) from Debian's libmujoco-samples, read by eomgen-mjcf,
# folded and free as the robots above; without them the binary times the arms and the chain.
set(pin_humanoid /usr/share/mujoco/model/humanoid/humanoid.xml)
if(TARGET eom::mjcf_tool AND EXISTS "${pin_humanoid}")
  add_eom_model(pin_humanoid_folded MJCF "${pin_humanoid}" KERNELS ${kernels} FIXED_PARAMETERS ALL)
  add_eom_model(pin_humanoid_free MJCF "${pin_humanoid}" KERNELS ${kernels})
  foreach(variant folded free)
    target_compile_options(pin_humanoid_${variant} PRIVATE -O3 -march=native)
    target_link_libraries(eom_bench_pinocchio PRIVATE pin_humanoid_${variant})
  endforeach()
  get_target_property(pin_humanoid_header pin_humanoid_folded EOMGEN_HEADER)
  cmake_path(GET pin_humanoid_header PARENT_PATH pin_humanoid_header_dir)
  target_include_directories(eom_bench_pinocchio PRIVATE "${pin_humanoid_header_dir}")
  target_compile_definitions(eom_bench_pinocchio PRIVATE EOM_PIN_HUMANOID)
else()
  message(STATUS "eom_bench_pinocchio: the arms and the chain only (the humanoid needs MuJoCo, "
                 "libmujoco-dev, and ${pin_humanoid}, libmujoco-samples)")
endif()
target_compile_definitions(eom_bench_pinocchio PRIVATE
    EOM_ROBOTS_DIR="${PROJECT_SOURCE_DIR}/models/robots"
    EOM_PINOCCHIO_CHAIN_URDF="${chain_urdf}"
    EOM_PINOCCHIO_ROMEO_URDF="${pin_romeo}"
    EOM_PINOCCHIO_CC="${EOM_PINOCCHIO_CC}")
target_include_directories(eom_bench_pinocchio SYSTEM PRIVATE "${prefix}/include"
                           ${Boost_INCLUDE_DIRS} "${EOM_QD_INCLUDE}")
target_include_directories(eom_bench_pinocchio PRIVATE "${PROJECT_SOURCE_DIR}/tests/support")
target_link_libraries(eom_bench_pinocchio PRIVATE eom_pinocchio_codegen eom_urdf "${EOM_QD_LIB}")
set_target_properties(eom_bench_pinocchio PROPERTIES BUILD_RPATH "${prefix}/lib")
# Pinocchio's and CppAD's headers are not -Wall -Werror clean: no eom_warnings here.
target_compile_options(eom_bench_pinocchio PRIVATE -O3 -march=native)

# eom_bench_pinocchio_contacts (bench/bench_pinocchio_contacts.cpp): eomgen's contact kernels
# (docs/CONTRACT.md §3, CONTACTS) for Solo12 on a free base, two sets (four point feet; one trot
# pair), and for MuJoCo's humanoid (two flat feet; one), every parameter folded, against
# Pinocchio's constraint and impulse dynamics and their derivatives, and Pinocchio's CppADCodeGen
# output of the first two (it generates no impulse code).
add_eom_model(pin_solo12_contacts URDF "${PROJECT_SOURCE_DIR}/models/robots/solo12.urdf"
              FLOATING_BASE
              CONTACTS stance=FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT trot=FL_FOOT,HR_FOOT
              KERNELS contact_dynamics impulse_dynamics contact_dynamics_derivatives
                      impulse_dynamics_derivatives
              FIXED_PARAMETERS ALL)
target_compile_options(pin_solo12_contacts PRIVATE -O3 -march=native)
add_executable(eom_bench_pinocchio_contacts bench_pinocchio_contacts.cpp)
# The humanoid (above), read by eomgen-mjcf; without it the binary times Solo12 alone.
if(TARGET eom::mjcf_tool AND EXISTS "${pin_humanoid}")
  add_eom_model(pin_humanoid_contacts MJCF "${pin_humanoid}"
                CONTACTS double=left_foot:6d,right_foot:6d single=right_foot:6d
                KERNELS contact_dynamics impulse_dynamics contact_dynamics_derivatives
                        impulse_dynamics_derivatives
                FIXED_PARAMETERS ALL)
  target_compile_options(pin_humanoid_contacts PRIVATE -O3 -march=native)
  get_target_property(pin_humanoid_header pin_humanoid_contacts EOMGEN_HEADER)
  cmake_path(GET pin_humanoid_header PARENT_PATH pin_humanoid_header_dir)
  target_include_directories(eom_bench_pinocchio_contacts PRIVATE "${pin_humanoid_header_dir}")
  target_link_libraries(eom_bench_pinocchio_contacts PRIVATE pin_humanoid_contacts)
  target_compile_definitions(eom_bench_pinocchio_contacts PRIVATE EOM_PIN_HUMANOID)
else()
  message(STATUS "eom_bench_pinocchio_contacts: Solo12 only (the humanoid needs MuJoCo, "
                 "libmujoco-dev, and ${pin_humanoid}, libmujoco-samples)")
endif()
target_compile_definitions(eom_bench_pinocchio_contacts PRIVATE
    EOM_SOLO12_URDF="${PROJECT_SOURCE_DIR}/models/robots/solo12.urdf"
    EOM_PINOCCHIO_CC="${EOM_PINOCCHIO_CC}")
target_include_directories(eom_bench_pinocchio_contacts PRIVATE "${PROJECT_SOURCE_DIR}/tests/support")
target_link_libraries(eom_bench_pinocchio_contacts PRIVATE pin_solo12_contacts eom_pinocchio_codegen
                      eom_urdf)
set_target_properties(eom_bench_pinocchio_contacts PROPERTIES BUILD_RPATH "${prefix}/lib")
# Pinocchio's and CppAD's headers are not -Wall -Werror clean (and mark the contact API
# deprecated): no eom_warnings here.
target_compile_options(eom_bench_pinocchio_contacts PRIVATE -O3 -march=native
                       -Wno-deprecated-declarations)
