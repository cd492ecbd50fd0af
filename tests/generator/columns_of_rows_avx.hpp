// columns_of_rows of generator/src/dense_solve.inc as compiled with -mavx (columns_of_rows_avx.cpp),
// for test_dense_solve.cpp to compare with the form it compiles itself (without AVX).
#pragma once

namespace columns_avx {
// Whether the file was compiled with AVX (the transposing form); the caller asks the CPU.
bool compiled_with_avx() noexcept;
// columns_of_rows<rows, step>(b, count, sign, out) for the (rows, step) that
// test_dense_solve.cpp takes (a humanoid's 27 velocity rows, read in reverse as the contact
// kernels read them, and in order; its six force rows; sizes around the four-row blocks); false
// for others.
bool columns_of_rows(int rows, int step, const double* b, int count, double sign, double* out) noexcept;
}  // namespace columns_avx
