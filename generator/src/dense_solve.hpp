// The looped form's dense routine compiled into the generator, from the text it copies into
// generated sources (dense_solve.inc): the Taylor evaluator runs it with run-time sizes, the
// emitters read its array layout, tests/generator checks it against eom::linalg.
#pragma once

#include <cmath>
#include <cstdint>  // aligned_rows
#if defined(__AVX__)
#include <immintrin.h>  // columns_of_rows' transposing form
#endif

#include "eomgen/graph.hpp"  // pivot_ok

namespace eom::gen::dense {

// What a generated source defines before the routine.
inline bool pivot_ok(double pivot, double diagonal) noexcept { return gen::pivot_ok(pivot, diagonal); }
inline bool all_finite(const double* x, int n) noexcept {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(x[i])) return false;
  return true;
}

#include "dense_solve.inc"

}  // namespace eom::gen::dense
