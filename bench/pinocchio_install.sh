#!/usr/bin/env bash
# Builds the codegen peer for bench/pinocchio.py: CppAD, CppADCodeGen and Pinocchio (with its
# CppADCodeGen support, everything else off) from their source trees, into one prefix. Outside the
# repository and never needed by anything else in eomgen.
#
#   CPPAD_SRC=... CPPADCG_SRC=... PINOCCHIO_SRC=... bench/pinocchio_install.sh [prefix]
#
# Sources (the versions of docs/benchmarks/pinocchio.md; the public repositories):
#   CppAD         coin-or/CppAD, tag 20240000.7 (CppADCodeGen 2.5.0 needs a 2024 CppAD)
#   CppADCodeGen  joaoleal/CppADCodeGen, v2.5.0
#   Pinocchio     stack-of-tasks/pinocchio, v3.7.0, with its cmake/ submodule
#                 (jrl-umi3218/jrl-cmakemodules at the commit Pinocchio pins) in $PINOCCHIO_SRC/cmake
# Debian packages: cmake g++ make libeigen3-dev libboost-dev libboost-filesystem-dev
#   libboost-serialization-dev libboost-system-dev googletest (CppADCodeGen's configure wants
#   googletest's sources; nothing of it is built). About 2 minutes on one core: everything used is
#   header-only but CppAD's small run-time library.
set -euo pipefail
PREFIX=$(realpath -m "${1:-/opt/eom-peer}")
: "${CPPAD_SRC:?the CppAD source tree}" "${CPPADCG_SRC:?the CppADCodeGen source tree}"
: "${PINOCCHIO_SRC:?the Pinocchio source tree (with cmake/ filled)}"
[ -f "$PINOCCHIO_SRC/cmake/base.cmake" ] ||
  { echo "pinocchio_install.sh: $PINOCCHIO_SRC/cmake is empty: put jrl-cmakemodules there" >&2; exit 1; }
BUILD=${BUILD:-$PREFIX/build}
JOBS=${JOBS:-2}
mkdir -p "$PREFIX" "$BUILD"

# 1. CppAD: its own install variables; only cppad_lib is built (tests are not in `all`).
cmake -S "$CPPAD_SRC" -B "$BUILD/cppad" -DCMAKE_BUILD_TYPE=Release -Dcppad_prefix="$PREFIX" \
      -Dcmake_install_libdirs=lib -Dcmake_install_includedirs=include -Dcppad_testvector=cppad
cmake --build "$BUILD/cppad" -j"$JOBS" --target install

# 2. CppADCodeGen, header-only. Its configure always reads test/CMakeLists.txt, which fetches
#    googletest: pointed at Debian's googletest sources, offline.
cmake -S "$CPPADCG_SRC" -B "$BUILD/cppadcg" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_INSTALL_PREFIX="$PREFIX" -DCPPAD_HOME="$PREFIX" -DCREATE_DOXYGEN_DOC=OFF \
      -DFETCHCONTENT_FULLY_DISCONNECTED=ON -DFETCHCONTENT_SOURCE_DIR_GOOGLETEST=/usr/src/googletest \
      -DINSTALL_GTEST=OFF
cmake --build "$BUILD/cppadcg" -j"$JOBS" --target install

# 3. Pinocchio, header-only (no template instantiation). Pinocchio 3.7.0 sets a PUBLIC compile
#    definition on what is then an INTERFACE target, which CMake refuses ("may only set INTERFACE
#    properties on INTERFACE targets"): the two lines get the scope Pinocchio computes (idempotent).
sed -i \
  -e 's/(${PROJECT_NAME}_cppadcg PUBLIC CPPAD_DEBUG_AND_RELEASE)/(${PROJECT_NAME}_cppadcg ${CPPADCG_SCOPE} CPPAD_DEBUG_AND_RELEASE)/' \
  -e 's/(${PROJECT_NAME}_cppad PUBLIC CPPAD_DEBUG_AND_RELEASE)/(${PROJECT_NAME}_cppad ${CPPAD_SCOPE} CPPAD_DEBUG_AND_RELEASE)/' \
  "$PINOCCHIO_SRC/src/CMakeLists.txt"
off=()
for option in AUTODIFF CASADI URDF SDF COLLISION OPENMP EXTRA; do
  off+=("-DBUILD_WITH_${option}_SUPPORT=OFF")
done
cmake -S "$PINOCCHIO_SRC" -B "$BUILD/pinocchio" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_INSTALL_PREFIX="$PREFIX" -DCMAKE_INSTALL_LIBDIR=lib -DCMAKE_PREFIX_PATH="$PREFIX" \
      -DBUILD_WITH_CODEGEN_SUPPORT=ON "${off[@]}" -DBUILD_PYTHON_INTERFACE=OFF \
      -DBUILD_WITH_LIBPYTHON=OFF -DGENERATE_PYTHON_STUBS=OFF -DBUILD_TESTING=OFF \
      -DBUILD_BENCHMARK=OFF -DBUILD_UTILS=OFF -DBUILD_DOCUMENTATION=OFF \
      -DINSTALL_DOCUMENTATION=OFF -DENABLE_TEMPLATE_INSTANTIATION=OFF
cmake --build "$BUILD/pinocchio" -j"$JOBS" --target install
echo "pinocchio_install.sh: installed in $PREFIX; next: bench/pinocchio.py --prefix $PREFIX"
