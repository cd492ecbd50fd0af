// What emit.cpp and emit_taylor.cpp share (private to the generator library).
#pragma once

#include <fmt/format.h>

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "eomgen/kernels.hpp"

namespace eom::gen::detail {

using Buffer = fmt::memory_buffer;

// A double literal that reads back to exactly v.
std::string literal(double v);

// head + items joined by separator and a space + tail, wrapped at 100 columns with continuation
// lines aligned after head (which ends with the opening parenthesis).
std::string wrap(std::string_view head, const std::vector<std::string>& items, std::string_view tail,
                 std::string_view separator = ",");

// The C++ expression of node n's value (a non-leaf) from its arguments' operands.
std::string expression(const Graph& g, NodeId n, const std::function<std::string(NodeId)>& operand);

// The text of src/taylor_recurrences.inc (embedded at build time: one source for the generator's
// evaluator and the generated code).
std::string_view taylor_recurrences_text();

// Writes the taylor_coefficients kernel; returns its statement count (order-0 pass plus one
// coefficient) and sets `workspace` to its slot count (taylor_workspace).
std::size_t write_taylor_kernel(const TracedModel& m, const Kernel& k, Buffer& out,
                                std::size_t& workspace);

}  // namespace eom::gen::detail
