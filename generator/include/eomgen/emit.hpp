// The emitter: kernels (graphs) to one C++ header and one source file per model (DESIGN §3).
//
// Each kernel is written from the cone of its own outputs and guards (dead code never reaches
// the page), one statement per node in id order, temporaries v0, v1, ... numbered in the order
// they appear; sin and cos of one argument are written side by side so the compiler computes
// them by one sincos call. A kernel of more than KernelWriter::part_size statements is written as
// a sequence of functions (<kernel>_part1, ...) sharing a stack workspace w[] for the values that
// cross from one part to another: compile time and memory stay near linear in the op count.
// The text depends on nothing but the graph, so it is byte-identical from run to run.
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

// ns: the C++ namespace of the generated code, possibly qualified (a::b).
EmittedFiles emit(const TracedModel& m, std::span<const Kernel> kernels, std::string_view ns);

}  // namespace eom::gen
