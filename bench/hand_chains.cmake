# The generated forward_dynamics of eom::models::UndampedChain<N> in two forms, for the
# hand-derived comparison: hand_chain<N>_free (parameters free, the default)
# and hand_chain<N>_fixed (every parameter in FIXED_PARAMETERS at the model's defaults), and both
# again compiled with EOM_LIBMVEC (<name>_libmvec: sin and cos from glibc's libmvec). Included
# by tests/hand_chain (the agreement test) and bench/ (eom_bench_hand_chain), whichever comes
# first (the sizes built: the global property EOM_HAND_CHAIN_SIZES). N = 2, 5, 10 always
# (forward_dynamics only: about 16 s of build on 2 cores for all six and the test); N = 20 and 50
# only with EOM_BENCH_HAND_CHAINS (bench/hand_chain.py turns it on).
include_guard(GLOBAL)

option(EOM_BENCH_HAND_CHAINS "eom_bench_hand_chain: also N = 20 and 50" OFF)
set(EOM_HAND_CHAIN_SIZES 2 5 10)
if(EOM_BENCH_HAND_CHAINS)
  list(APPEND EOM_HAND_CHAIN_SIZES 20 50)
endif()
set_property(GLOBAL PROPERTY EOM_HAND_CHAIN_SIZES ${EOM_HAND_CHAIN_SIZES})

foreach(n IN LISTS EOM_HAND_CHAIN_SIZES)
  # UndampedChain<N>'s defaults (chain_detail::uniform(1, 1, 0)): m = l = 1, I = 1/12, c = 0,
  # g = 9.81; 0.08333333333333333 is the shortest decimal that reads back as 1.0 / 12.
  set(fixed "")
  foreach(i RANGE 1 ${n})
    list(APPEND fixed m${i}=1 l${i}=1 I${i}=0.08333333333333333 c${i}=0)
  endforeach()
  list(APPEND fixed g=9.81)
  set(header "${PROJECT_SOURCE_DIR}/models/chain.hpp")
  add_eom_model(hand_chain${n}_free HEADER "${header}"
                CLASS eom::models::UndampedChain<${n}> KERNELS forward_dynamics)
  add_eom_model(hand_chain${n}_fixed HEADER "${header}"
                CLASS eom::models::UndampedChain<${n}> KERNELS forward_dynamics
                FIXED_PARAMETERS ${fixed})
  # The same two with sin and cos of the angles from glibc's libmvec (EOM_LIBMVEC, opt-in).
  add_eom_model(hand_chain${n}_free_libmvec HEADER "${header}"
                CLASS eom::models::UndampedChain<${n}> KERNELS forward_dynamics)
  add_eom_model(hand_chain${n}_fixed_libmvec HEADER "${header}"
                CLASS eom::models::UndampedChain<${n}> KERNELS forward_dynamics
                FIXED_PARAMETERS ${fixed})
  target_compile_definitions(hand_chain${n}_free_libmvec PRIVATE EOM_LIBMVEC)
  target_compile_definitions(hand_chain${n}_fixed_libmvec PRIVATE EOM_LIBMVEC)
  # The benchmark's flags, so that generated and hand-derived code are compiled alike.
  foreach(variant free fixed free_libmvec fixed_libmvec)
    target_compile_options(hand_chain${n}_${variant} PRIVATE -O3 -march=native)
  endforeach()
endforeach()
