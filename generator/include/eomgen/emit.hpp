// The emitter: kernels (graphs) to one C++ header and one source file per model (docs/CONTRACT.md §3).
//
// Each kernel is written from the cone of its own outputs and guards (dead code never reaches
// the page), one statement per node in id order, temporaries v0, v1, ... numbered in the order
// they appear; sin and cos of one argument are written side by side so the compiler computes
// them by one sincos call. A kernel of more than split_from statements (eomgen/program.hpp) is
// written as a sequence of functions of part_size statements (<kernel>_part1, ...) sharing a
// workspace w[] for the values that cross from one part to another: compile time and memory stay
// near linear in the op count. The workspace (and the looped form's system array) is the
// caller's in the overload <kernel>(..., double* work) of <kernel>_workspace doubles
// (taylor_coefficients: `scratch`); the plain signature lends it a stack array.
// The text depends on nothing but the graph and the options, so it is byte-identical from run to
// run.
//
// A looped kernel (Kernel::looped; the form is chosen by build_kernels, eomgen/kernels.hpp) is
// written as straight-line statements of M, f, C, γ into the workspace, one call of the dense
// routine solve_dense_system (src/dense_solve.inc, written once per source file), and for the
// derivative kernels straight-line statements of the right-hand sides at the q̈ and μ it
// computed (by rows, the directions side by side), solved by solve_dense_rows on the factors it
// left. The contact derivative kernels' row form (Kernel::row_solve) writes the factors' nonzeros
// and the right-hand sides by rows the same way, and solves them by straight-line row steps
// (<kernel>_rows1, ...), each a loop across the directions.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "eomgen/kernels.hpp"

namespace eom::gen {

struct EmittedFiles {
  std::string header;  // <name>.hpp
  std::string source;  // <name>.cpp
  std::vector<std::pair<KernelId, std::size_t>> operation_counts;
};

// forward_dynamics_batch (on request) evaluates batch_lanes states at once in GCC vector
// extensions, always unrolled (build_kernels refuses it where the solve is looped).
inline constexpr int default_batch_lanes = 4;  // AVX2: 4 doubles in a 256-bit register

struct EmitOptions {
  int batch_lanes = default_batch_lanes;  // 2, 4 or 8
};

// ns: the C++ namespace of the generated code, possibly qualified (a::b).
EmittedFiles emit(const TracedModel& m, std::span<const Kernel> kernels, std::string_view ns,
                  const EmitOptions& options = {});

}  // namespace eom::gen
