// The emitter: kernels (graphs) to one C++ header and one source file per model (docs/CONTRACT.md §3).
//
// Each kernel is written from the cone of its own outputs and guards (dead code never reaches
// the page), one statement per node in id order, temporaries v0, v1, ... numbered in the order
// they appear; sin and cos of one argument are written side by side so the compiler computes
// them by one sincos call. A kernel of more than KernelWriter::part_size statements is written as
// a sequence of functions (<kernel>_part1, ...) sharing a workspace w[] for the values that
// cross from one part to another: compile time and memory stay near linear in the op count. The
// workspace (and the looped form's system array) is the caller's in the overload
// <kernel>(..., double* work) of <kernel>_workspace doubles; the plain signature lends it a stack
// array. (The Taylor kernel's split passes still keep theirs on the stack.)
// The text depends on nothing but the graph and the options, so it is byte-identical from run to
// run.
//
// forward_dynamics solves [M Cᵀ; C 0][q̈; μ] = [f; −γ] in one of two forms:
//   unrolled  the LDLᵀ factorization and the range-space solves as straight-line statements:
//             structural zeros of M vanish and every operand is a register or a constant, but
//             a dense M costs O(nq³) statements, which dominate compile time of big models
//   looped    M, f, C, γ as straight-line statements into a stack array, then one small dense
//             routine (solve_dense_system, written once per source file) factors and solves them
//             with loops: O(nq²) statements
// `automatic` takes the looped form from nq >= looped_solve_from coordinates, where it is faster
// to compile and no slower to run (docs/benchmarks/scaling.md has the measurement). The other
// kernels built on the factorization (derivatives, Taylor coefficients) stay unrolled.
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

enum class SolveForm { automatic, unrolled, looped };
inline constexpr int looped_solve_from = 30;

// The form forward_dynamics takes in a model of nq coordinates: the one place that decides.
constexpr SolveForm solve_form(int nq, SolveForm asked) {
  if (asked != SolveForm::automatic) return asked;
  return nq >= looped_solve_from ? SolveForm::looped : SolveForm::unrolled;
}

// forward_dynamics_batch (on request) evaluates batch_lanes states at once in GCC vector
// extensions, always in the unrolled form: where forward_dynamics is looped (a model of
// looped_solve_from coordinates or more, or SolveForm::looped asked for) it is written only with
// SolveForm::unrolled asked for explicitly (else a generation error names the model).
inline constexpr int default_batch_lanes = 4;  // AVX2: 4 doubles in a 256-bit register

struct EmitOptions {
  SolveForm solve = SolveForm::automatic;
  int batch_lanes = default_batch_lanes;  // 2, 4 or 8
};

// ns: the C++ namespace of the generated code, possibly qualified (a::b).
EmittedFiles emit(const TracedModel& m, std::span<const Kernel> kernels, std::string_view ns,
                  const EmitOptions& options = {});

}  // namespace eom::gen
