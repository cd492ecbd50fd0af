// columns_of_rows (generator/src/dense_solve.inc) compiled with -mavx (tests/generator/CMakeLists.txt),
// where it transposes four rows of four columns in registers. Its own copy of the routine (in a
// namespace of this file), so that its instances are not those test_dense_solve.cpp compiles.
#include "columns_of_rows_avx.hpp"

#include <cmath>
#include <cstdint>
#if defined(__AVX__)
#include <immintrin.h>
#endif

#include "eomgen/graph.hpp"  // pivot_ok

namespace columns_avx {
namespace routine {
inline bool pivot_ok(double pivot, double diagonal) noexcept { return eom::gen::pivot_ok(pivot, diagonal); }
#include "dense_solve.inc"
}  // namespace routine

bool compiled_with_avx() noexcept {
#if defined(__AVX__)
  return true;
#else
  return false;
#endif
}

bool columns_of_rows(int rows, int step, const double* b, int count, double sign, double* out) noexcept {
#define EOM_SHAPE(r, s)                                            \
  if (rows == r && step == s) {                                   \
    routine::columns_of_rows<r, s>(b, count, sign, out);          \
    return true;                                                  \
  }
  EOM_SHAPE(27, -72) EOM_SHAPE(27, 72) EOM_SHAPE(6, 72) EOM_SHAPE(1, 8) EOM_SHAPE(3, -5) EOM_SHAPE(4, 4)
  EOM_SHAPE(5, 9) EOM_SHAPE(8, -8)
#undef EOM_SHAPE
  return false;
}
}  // namespace columns_avx
