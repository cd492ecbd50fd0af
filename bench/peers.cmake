# eom_bench_peers: the generated kernels against the peers a user would pick —
# eom::Reference (operator overloading), ADOL-C (a taped run-time AD) and SymPy (LagrangesMethod,
# cse, C printer) — for the bundled models and Chain<N>, N = 2, 5, 10, 20, 50; and
# eom_chain_tracer, the tracer of Chain<N> for the generator scaling study (bench/scaling.py).
# ADOL-C and SymPy are optional: without them the target is built without that route, and
# configuring says what is missing. bench/run_peers.sh runs the benchmark and writes
# docs/benchmarks/kernels.md.

# Chain<N> for the sizes the bundled models lack (chain10 is bundled), with the three kernels the
# benchmark times only: all of them would make N = 50 a long compile.
set(eom_peer_chain_sizes 2 5 20 50)
foreach(n IN LISTS eom_peer_chain_sizes)
  add_eom_model(bench_chain${n} HEADER ../models/chain.hpp CLASS eom::models::Chain<${n}>
                KERNELS mass_matrix coriolis forward_dynamics)
  target_compile_options(bench_chain${n} PRIVATE -O3 -march=native)  # the benchmark's flags
endforeach()

find_package(Threads REQUIRED)  # the benchmarks run on a thread with a large stack
add_executable(eom_bench_peers bench_peers.cpp)
get_property(peer_bundled GLOBAL PROPERTY EOM_BUNDLED_MODELS)
foreach(model IN LISTS peer_bundled)
  # As in eom_bench_kernels: the bundled kernels compiled with the benchmark's flags.
  get_target_property(out_dir ${model} EOMGEN_OUTPUT_DIR)
  target_sources(eom_bench_peers PRIVATE "${out_dir}/${model}.cpp")
  target_include_directories(eom_bench_peers BEFORE PRIVATE "${out_dir}")
  add_dependencies(eom_bench_peers ${model})
endforeach()
foreach(n IN LISTS eom_peer_chain_sizes)
  target_link_libraries(eom_bench_peers PRIVATE bench_chain${n})
endforeach()
target_include_directories(eom_bench_peers PRIVATE "${PROJECT_SOURCE_DIR}"
                                                   "${PROJECT_SOURCE_DIR}/tests/support")
target_link_libraries(eom_bench_peers PRIVATE eom_runtime eom_models eom_warnings
                                              benchmark::benchmark Threads::Threads)
target_compile_options(eom_bench_peers PRIVATE -O3 -march=native)

option(EOM_BENCH_WITH_ADOLC "eom_bench_peers: the ADOL-C route, when ADOL-C is found" ON)
option(EOM_BENCH_WITH_SYMPY "eom_bench_peers: the SymPy route, when SymPy is found" ON)

# ---- ADOL-C (Debian: libadolc-dev) ----
if(EOM_BENCH_WITH_ADOLC)
  find_path(EOM_ADOLC_INCLUDE_DIR adolc/adolc.h)
  find_library(EOM_ADOLC_LIBRARY adolc)
endif()
if(NOT EOM_BENCH_WITH_ADOLC)
  message(STATUS "eom_bench_peers: the ADOL-C route is off (EOM_BENCH_WITH_ADOLC)")
elseif(EOM_ADOLC_INCLUDE_DIR AND EOM_ADOLC_LIBRARY)
  message(STATUS "eom_bench_peers: ADOL-C found (${EOM_ADOLC_LIBRARY})")
  target_compile_definitions(eom_bench_peers PRIVATE EOM_BENCH_ADOLC=1)
  target_include_directories(eom_bench_peers SYSTEM PRIVATE "${EOM_ADOLC_INCLUDE_DIR}")
  target_link_libraries(eom_bench_peers PRIVATE "${EOM_ADOLC_LIBRARY}")
else()
  message(STATUS "eom_bench_peers: ADOL-C not found (adolc/adolc.h, libadolc): the ADOL-C route "
                 "is left out; install it with: apt-get install libadolc-dev")
endif()

# ---- SymPy (Debian: python3-sympy) ----
# The interpreter: EOM_SYMPY_PYTHON if given, else the system's /usr/bin/python3 (where Debian's
# python3-sympy lives), else the first python3 on PATH; it must import sympy.
set(EOM_SYMPY_PYTHON "" CACHE FILEPATH "Python 3 interpreter with SymPy for eom_bench_peers")
# SymPy's LagrangesMethod grows about as N³ (about 20 s at N = 10, 5 to 12 minutes at N = 20 on
# a 2-core machine): chains above this size are not derived. bench/run_peers.sh sets 20; the
# default keeps an ordinary build (scripts/test.sh) to about a minute of SymPy.
set(EOM_SYMPY_MAX_LINKS 10 CACHE STRING "Largest Chain<N> whose SymPy code eom_bench_peers builds")
set(sympy_python "")
set(sympy_candidates "")
if(EOM_BENCH_WITH_SYMPY)
  set(sympy_candidates ${EOM_SYMPY_PYTHON} /usr/bin/python3)
  find_program(EOM_PATH_PYTHON3 python3)
  if(EOM_PATH_PYTHON3)
    list(APPEND sympy_candidates "${EOM_PATH_PYTHON3}")
  endif()
endif()
foreach(candidate IN LISTS sympy_candidates)
  if(EXISTS "${candidate}")
    execute_process(COMMAND "${candidate}" -c "import sympy; print(sympy.__version__)"
                    RESULT_VARIABLE rc OUTPUT_VARIABLE version ERROR_QUIET
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(rc EQUAL 0)
      set(sympy_python "${candidate}")
      break()
    endif()
  endif()
endforeach()
if(sympy_python)
  set(sympy_models spring_pendulum cartesian_pendulum double_pendulum closed_chain5)
  foreach(n 2 5 10 20 50)
    if(n LESS_EQUAL EOM_SYMPY_MAX_LINKS)
      list(APPEND sympy_models chain${n})
    endif()
  endforeach()
  message(STATUS "eom_bench_peers: SymPy ${version} found (${sympy_python}); SymPy code for "
                 "chains up to N = ${EOM_SYMPY_MAX_LINKS} (EOM_SYMPY_MAX_LINKS)")
  set(sympy_dir "${CMAKE_CURRENT_BINARY_DIR}/sympy")
  set(sympy_sources "")
  foreach(model IN LISTS sympy_models)
    set(out "${sympy_dir}/sympy_${model}.cpp" "${sympy_dir}/sympy_${model}.hpp")
    add_custom_command(
      OUTPUT ${out}
      COMMAND "${sympy_python}" "${CMAKE_CURRENT_SOURCE_DIR}/sympy_models.py" ${model}
              --out-dir "${sympy_dir}" --stats "${sympy_dir}/sympy_${model}.json"
      COMMAND "${CMAKE_COMMAND}" -E touch ${out}  # the script rewrites only changed files
      DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/sympy_models.py"
      COMMENT "Deriving ${model} with SymPy (LagrangesMethod, cse, ccode)"
      VERBATIM)
    list(APPEND sympy_sources "${sympy_dir}/sympy_${model}.cpp")
    string(TOUPPER "${model}" upper)
    target_compile_definitions(eom_bench_peers PRIVATE EOM_BENCH_SYMPY_${upper}=1)
  endforeach()
  # SymPy's output with the benchmark's flags; its warnings are SymPy's, not ours.
  add_library(eom_sympy_peer STATIC ${sympy_sources})
  target_include_directories(eom_sympy_peer PUBLIC "${sympy_dir}")
  target_compile_options(eom_sympy_peer PRIVATE -O3 -march=native)
  target_link_libraries(eom_bench_peers PRIVATE eom_sympy_peer)
elseif(NOT EOM_BENCH_WITH_SYMPY)
  message(STATUS "eom_bench_peers: the SymPy route is off (EOM_BENCH_WITH_SYMPY)")
else()
  message(STATUS "eom_bench_peers: SymPy not found (no python3 among '${sympy_candidates}' "
                 "imports sympy): the SymPy route is left out; install it with: "
                 "apt-get install python3-sympy")
endif()

# The scaling study's tracer: add_eom_model()'s one-line tracer for every N of the study. Built
# by bench/scaling.py only (not part of `all`: it instantiates the generator for 12 models).
add_executable(eom_chain_tracer EXCLUDE_FROM_ALL chain_tracer.cpp)
target_link_libraries(eom_chain_tracer PRIVATE eom::generator eom_runtime eom_models eom_warnings)

# eom_bench_solve_forms: forward_dynamics of Chain<N> unrolled against looped (eomgen/kernels.hpp),
# and up to 30 links its derivatives and Taylor coefficients, generated by the scaling tracer with --solve, to place the
# generator's looped_solve_from.
set(solve_dir "${CMAKE_CURRENT_BINARY_DIR}/solve_forms")
set(solve_sources "")
foreach(n 5 10 20 30 50 100)
  set(solve_kernels --kernel forward_dynamics)
  if(n LESS_EQUAL 30)  # unrolled, the derivatives are 577 066 operations at 50 links
    list(APPEND solve_kernels --kernel forward_dynamics_derivatives --kernel taylor_coefficients)
  endif()
  foreach(form unrolled looped)
    set(name solve_chain${n}_${form})
    add_custom_command(
      OUTPUT "${solve_dir}/${name}.cpp" "${solve_dir}/${name}.hpp"
      COMMAND eom_chain_tracer ${n} --name ${name} --out-dir "${solve_dir}"
              ${solve_kernels} --solve ${form}
      DEPENDS eom_chain_tracer
      COMMENT "Generating ${name}"
      VERBATIM)
    list(APPEND solve_sources "${solve_dir}/${name}.cpp")
  endforeach()
endforeach()
add_executable(eom_bench_solve_forms EXCLUDE_FROM_ALL bench_solve_forms.cpp ${solve_sources})
target_include_directories(eom_bench_solve_forms PRIVATE "${solve_dir}")
target_link_libraries(eom_bench_solve_forms PRIVATE eom_warnings benchmark::benchmark)
target_compile_options(eom_bench_solve_forms PRIVATE -O3 -march=native)
