// What emit.cpp and emit_taylor.cpp share (private to the generator library).
#pragma once

#include <fmt/format.h>

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "eom/multibody/scene.hpp"
#include "eomgen/emit.hpp"
#include "eomgen/kernels.hpp"
#include "eomgen/taylor.hpp"
#include "dense_solve.hpp"

namespace eom::gen::detail {

using Buffer = fmt::memory_buffer;

// A double literal that reads back to exactly v.
std::string literal(double v);
// A C++ string literal of s, quotes included (a frame name may hold any character).
std::string string_literal(std::string_view s);

// head + items joined by separator and a space + tail, wrapped at 100 columns with continuation
// lines aligned after head (which ends with the opening parenthesis).
std::string wrap(std::string_view head, const std::vector<std::string>& items, std::string_view tail,
                 std::string_view separator = ",");

// A model header's scene table (eom/multibody/scene.hpp), lines ending in '\n':
// `  static constexpr std::array<type, n> name{{`, one wrapped `{fields},` line per item, `  }};`
// (`std::array<type, 0> name{};` where there is none).
std::string scene_table(std::string_view type, std::string_view name,
                        const std::vector<std::vector<std::string>>& items);
// `  static constexpr eom::SolverOptions solver_options{...};` (no '\n'), every field stated, the
// reals written by `number`.
std::string solver_options_text(const eom::SolverOptions& o,
                                const std::function<std::string(double)>& number);

// The C++ expression of node n's value (a non-leaf) from its arguments' operands; math prefixes
// the name of a math function (std::sin; the batch kernel's lanewise batch_sin).
std::string expression(const Graph& g, NodeId n, const std::function<std::string(NodeId)>& operand,
                       std::string_view math = "std::");

// The plain signature of a kernel with an overload taking its scratch (`work`, or `scratch` when
// the kernel already has a `work`): it lends the overload `size` doubles on the stack. With
// `trailing` (e.g. "const double* pc") both take that argument last; `device` marks it
// EOM_HOST_DEVICE (host_device below).
std::string lending_overload(const Signature& sig, std::size_t size, bool device = false,
                             std::string_view trailing = {});

// The helpers in a source's unnamed namespaces (finiteness tests, Taylor recurrences, batch lane
// functions) are written whole, whichever of them its kernels call: clang's -Wunused-function,
// which GCC does not raise for inline functions, is off between these two lines (push and pop, so
// that a unity build's next file keeps the caller's settings).
inline constexpr std::string_view clang_unused_begin =
    "#if defined(__clang__)\n#pragma clang diagnostic push\n"
    "#pragma clang diagnostic ignored \"-Wunused-function\"\n#endif\n";
inline constexpr std::string_view clang_unused_end = "#if defined(__clang__)\n#pragma clang diagnostic pop\n#endif\n";

// The mark of a function a GPU can run, on a line of its own before its definition or
// declaration: the generated header defines EOM_HOST_DEVICE as __host__ __device__ under nvcc
// and as nothing for a host compiler. What is not marked (the overloads that read the
// thread_local parameter caches, the Taylor kernel) is host code in an nvcc build too.
inline constexpr std::string_view host_device = "EOM_HOST_DEVICE\n";
// GCC's vector code (the batch kernel, libmvec) stays out of nvcc's device pass: written between
// host_pass_begin and host_pass_end, it is compiled for the host alone (by any compiler).
inline constexpr std::string_view host_pass_begin = "#if !defined(__CUDA_ARCH__)\n";
inline constexpr std::string_view host_pass_end = "#endif\n";

// The text of src/taylor_recurrences.inc (embedded at build time: one source for the generator's
// evaluator and the generated code).
std::string_view taylor_recurrences_text();

// The text of src/dense_solve.inc, the looped form's dense LDL' routine (embedded at build time,
// written once into a source that uses it; tests/generator compiles the same file and checks it
// against eom::linalg).
std::string_view dense_solve_text();
// Copies of this many values or more from scattered places into an array are written as one loop
// over index tables, not a statement each (at 70 links, 4900 scattered copies cost GCC's SLP
// vectorizer 0.9 GB and three quarters of the compile time).
inline constexpr std::size_t gather_from = 32;

// The looped kernels' array: its layout is dense::DenseLayout (dense_solve.hpp), what they write
// into it eomgen/taylor.hpp's dense_system_entries.

// Writes the taylor_coefficients kernel; returns its statement count (order-0 pass plus one
// coefficient) and sets `workspace` to its slot count (taylor_workspace) and `scratch` to the
// size of its overload taking the parts' crossing arrays (0: not split, no such overload).
std::size_t write_taylor_kernel(const TracedModel& m, const Kernel& k, Buffer& out,
                                std::size_t& workspace, std::size_t& scratch);

// forward_dynamics_batch (emit_batch.cpp): the vector types and lanewise helpers (its own
// unnamed namespace, once per source), the kernel's definition (returns its statement count; throws
// std::invalid_argument naming the model when the options exclude it), the header's
// `batch_lanes` constant, and its declaration (or, in_struct, the Kernels member forwarding to it).
std::string batch_support_text(int lanes);
std::size_t write_batch_kernel(const TracedModel& m, const Kernel& k, const EmitOptions& options,
                               Buffer& out);
std::string batch_lanes_declaration(int lanes);
std::string batch_declaration(std::string_view qualified, bool in_struct);

}  // namespace eom::gen::detail
