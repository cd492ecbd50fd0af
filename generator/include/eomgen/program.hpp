// A kernel lowered to a flat instruction list: the step between the graph and the text.
//
//   lower()  schedules a kernel's cone (dead code never reaches it; id order, or by_steps the
//            order its statements can start (Kernel::by_steps); a cos right after
//            the sin of the same argument, so the compiler makes one sincos of them), cuts it at
//            the parameter cache, gives the inputs' sines and cosines to one sincos_n call, splits
//            it into parts of part_size instructions and gives every value its place: a local
//            temporary, or a workspace slot when it crosses parts (slots are reused once no later
//            part reads them); a split kernel's outputs are written where they go by the part
//            that computes them, and read back from there by later parts
//   run()    interprets a program in double, instruction by instruction, reading and writing the
//            places the emitter prints; tests check it against evaluate() on the graph, so a
//            scheduling or slot-reuse mistake shows without compiling anything
//
// The emitter (src/emit.cpp) prints a program; it decides nothing about order or storage.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "eomgen/graph.hpp"
#include "eomgen/kernels.hpp"

namespace eom::gen {

// Statements per function: GCC's optimizer is superlinear in a function's size, so a long
// kernel compiles far faster as a sequence of parts than as one function.
inline constexpr std::size_t part_size = 1000;
// A kernel is split only above this many statements: a short last part after a full one costs a
// workspace round trip of every value live across it for nothing (the Panda's inverse dynamics,
// 1,013 operations: 0.86–0.89× Pinocchio's generated RNEA in two parts, 0.77× in one;
// docs/benchmarks/pinocchio.md). Taylor mode splits from part_size (emit_taylor.cpp).
inline constexpr std::size_t split_from = part_size + part_size / 2;

// Distinct angles (inputs) from which their sines and cosines come from one sincos_n call.
inline constexpr std::size_t vector_trig_from = 4;

// The sine or cosine of an input: what sincos_n computes.
bool is_angle(const Graph& g, NodeId n);

// Where a value is read from or written to.
struct Place {
  enum class Kind : std::uint8_t {
    constant,   // a literal: value
    input,      // an input: t, or input[index]
    cached,     // pc[index], the parameter cache
    trig,       // sincos_n's result: the sine of angles[index], or the cosine of angles[index - k]
    local,      // the temporary v<index>
    workspace,  // w[index], shared between parts
    output,     // the kernel's output index (of Program::outputs): only in a split program
  };
  Kind kind = Kind::constant;
  InputKind input = InputKind::t;
  int index = 0;
  double value = 0;
  bool boolean = false;  // a condition (a workspace slot holds it as 1.0 / 0.0)

  friend bool operator==(const Place&, const Place&) = default;
};

struct Instruction {
  Op op;
  bool guard;                 // the kernel fails unless this condition holds; `to` unused
  Place to;                   // a local or a workspace slot
  std::array<Place, 3> from;  // arity(op) of them
};

// Output `output` repeats the value instruction `after` wrote into another output (M's upper
// triangle): a split program copies it there right away.
struct Copy {
  std::size_t after;
  int output;
};

struct Program {
  std::vector<Instruction> code;  // in order; with parts, part i is [i part_size, (i + 1) part_size)
  std::vector<Place> outputs;     // the kernel's outputs, in order (an output place: written by
                                  // its instruction, or by a copy)
  std::vector<Copy> copies;       // in instruction order
  std::vector<Place> inputs;      // the inputs it reads, in the order the model made them
  std::vector<Place> angles;      // inputs whose sin and cos are trig places (empty: none)
  std::size_t parts = 1;
  int slots = 0;                  // workspace slots of values crossing parts
  bool reads_cache = false;       // some instruction or output reads pc[]

  bool split() const { return parts > 1; }
};

struct LowerOptions {
  bool split = true;        // parts of part_size instructions, when longer
  bool vector_trig = true;  // one sincos_n call for vector_trig_from angles or more
};

// Workspace slots for values that cross parts, in the order they are written: value i is written
// in part written[i] and read last in part last_read[i] (>= written[i]; parts are numbered in
// the order they run, written[] does not decrease); a slot is free again for values written after
// its value's last reader. Returns each value's slot and adds the slots used to `count`.
std::vector<int> allocate_slots(std::span<const std::size_t> written, std::span<const std::size_t> last_read,
                                int& count);

// The program of kernel k with signature sig (its inputs bound what it may read). cached: per
// node, its index in the parameter cache or -1 (empty: no cache); the cone stops at cached nodes.
Program lower(const Graph& g, const Kernel& k, const Signature& sig, std::span<const int> cached = {},
              const LowerOptions& options = {});

// The outputs of p at x, with pc the parameter cache's values; nothing when a guard fails.
std::optional<std::vector<double>> run(const Program& p, const Point& x, std::span<const double> pc = {});

}  // namespace eom::gen
