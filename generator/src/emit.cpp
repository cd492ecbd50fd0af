#include "eomgen/emit.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <span>
#include <stdexcept>

#include "emit_detail.hpp"
#include "eom/numeric/linalg.hpp"
#include "eomgen/taylor.hpp"
#include "eomgen/optimize.hpp"
#include "eomgen/program.hpp"
#include "ops/print.hpp"

namespace eom::gen {

namespace detail {

std::string literal(double v) {
  if (std::isnan(v)) return "std::numeric_limits<double>::quiet_NaN()";
  if (std::isinf(v))
    return v > 0 ? "std::numeric_limits<double>::infinity()"
                 : "(-std::numeric_limits<double>::infinity())";
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return std::signbit(v) ? fmt::format("({})", s) : s;
}

std::string string_literal(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20)
      out += fmt::format("\\x{:02x}\"\"", static_cast<unsigned char>(c));  // "" ends the escape
    else
      out += c;
  }
  return out + '"';
}

std::string scene_table(std::string_view type, std::string_view name,
                        const std::vector<std::vector<std::string>>& items) {
  if (items.empty()) return fmt::format("  static constexpr std::array<{}, 0> {}{{}};\n", type, name);
  std::string out = fmt::format("  static constexpr std::array<{}, {}> {}{{{{\n", type, items.size(), name);
  for (const auto& fields : items) out += wrap("      {", fields, "},") + "\n";
  return out + "  }};\n";
}

std::string solver_options_text(const eom::SolverOptions& o,
                                const std::function<std::string(double)>& number) {
  auto list = [&](const auto& v) {
    std::vector<std::string> items;
    for (double x : v) items.push_back(number(x));
    return fmt::format("{{{}}}", fmt::join(items, ", "));
  };
  return wrap("  static constexpr eom::SolverOptions solver_options{",
              {fmt::format(".timestep = {}", number(o.timestep)),
               fmt::format(".impratio = {}", number(o.impratio)),
               fmt::format(".tolerance = {}", number(o.tolerance)),
               fmt::format(".iterations = {}", o.iterations),
               fmt::format(".noslip_iterations = {}", o.noslip_iterations),
               fmt::format(".noslip_tolerance = {}", number(o.noslip_tolerance)),
               fmt::format(".integrator = {}", o.integrator), fmt::format(".cone = {}", o.cone),
               fmt::format(".solver = {}", o.solver),
               fmt::format(".disable_flags = {}", o.disable_flags),
               fmt::format(".enable_flags = {}", o.enable_flags),
               fmt::format(".override_margin = {}", number(o.override_margin)),
               fmt::format(".override_softness = {{.solref = {}, .solimp = {}}}",
                           list(o.override_softness.solref), list(o.override_softness.solimp))},
              "};");
}

std::string wrap(std::string_view head, const std::vector<std::string>& items, std::string_view tail,
                 std::string_view separator) {
  constexpr std::size_t width = 100;
  std::string out, line(head);
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string piece = items[i] + std::string(i + 1 < items.size() ? separator : tail);
    const bool first = line.size() == head.size();
    if (!first && line.size() + 1 + piece.size() > width) {
      out += line + "\n";
      line = std::string(head.size(), ' ') + piece;
    } else {
      if (!first) line += ' ';
      line += piece;
    }
  }
  if (items.empty()) line += tail;
  return out + line;
}

std::string expression(const Graph& g, NodeId n, const std::function<std::string(NodeId)>& operand,
                       std::string_view math) {
  const Node& node = g[n];
  if (arity(node.op) == 0) throw std::logic_error("eomgen: no expression for a leaf");
  const ops::Text args[] = {{operand(node.arg[0])},
                            {arity(node.op) > 1 ? operand(node.arg[1]) : std::string()},
                            {arity(node.op) > 2 ? operand(node.arg[2]) : std::string()}};
  return ops::print(node.op, std::span<const ops::Text>(args, arity(node.op)), math).s;
}

}  // namespace detail

namespace {

using detail::Buffer;
using detail::literal;
using detail::wrap;


// taylor_coefficients' summary (kernels.cpp) for a model with quaternions in q.
constexpr std::string_view floating_taylor_summary =
    "Taylor coefficients of the motion through (t, q, qd) under the forward dynamics and\n"
    "// q' = G(q) qd, u held constant: qk[k*nq + i] = q_i^(k)(t)/k! (nq*(order + 1) values),\n"
    "// qdk[k*nv + i] = qd_i^(k)(t)/k! (nv*(order + 1)) for k = 0..order; work holds\n"
    "// taylor_workspace*(order + 1) doubles. False (outputs NaN) as forward_dynamics, when\n"
    "// order < 1 or order > taylor_max_order, or when a coefficient is not finite";

// The header's name of a size; nv is nq's name where the two are one (no free joint).
std::string_view dim_name(Dim d, const TracedModel& m) {
  switch (d) {
    case Dim::one: return "1";
    case Dim::three: return "3";
    case Dim::six: return "6";
    case Dim::nq: return "nq";
    case Dim::nv: return m.floating() ? "nv" : "nq";
    case Dim::nc: return "nc";
    case Dim::nu: return "nu";
    case Dim::np: return "np";
    case Dim::series: return "(order + 1)";
    case Dim::outputs: return "n";
    case Dim::contact: return "contact_rows[s]";
  }
  return "";
}

std::string length(const Signature::Output& o, const TracedModel& m) {
  if (o.count >= 0) return std::to_string(o.count);
  if (o.cols == Dim::one) return std::string(dim_name(o.rows, m));
  return fmt::format("{} * {}", dim_name(o.rows, m), dim_name(o.cols, m));
}

int size(Dim d, const TracedModel& m) {
  switch (d) {
    case Dim::one: return 1;
    case Dim::three: return 3;
    case Dim::six: return 6;
    case Dim::nq: return m.nq;
    case Dim::nv: return m.nv;
    case Dim::nc: return m.nc;
    case Dim::nu: return m.nu;
    case Dim::np: return m.np();
    case Dim::series: return 1;  // at least
    case Dim::outputs: return 0;  // the writer counts the kernel's outputs
    case Dim::contact: return 0;  // each case has its own (Signature::Output::count)
  }
  return 0;
}

// An output's length: its case's count where it varies by case, else rows × cols.
int output_size(const Signature::Output& o, const TracedModel& m) {
  return o.count >= 0 ? o.count : size(o.rows, m) * size(o.cols, m);
}

// "const double* q", "const double* p", "double* M" (names of unused inputs commented out)
std::vector<std::string> parameters(const Signature& sig, const std::vector<bool>* used,
                                    const TracedModel* m = nullptr, bool outputs = true) {
  std::vector<std::string> ps;
  for (const auto& e : sig.leading) ps.push_back(fmt::format("{} {}", e.type, e.name));
  for (InputKind k : sig.inputs) {
    const bool named = !used || (*used)[static_cast<int>(k)];
    const std::string n = named ? std::string(name(k)) : fmt::format("/*{}*/", name(k));
    ps.push_back(fmt::format("{} {}", is_scalar(k) ? "double" : "const double*", n));
  }
  if (sig.result != "double" && outputs)
    for (const auto& o : sig.outputs) {
      const bool empty = m && o.rows != Dim::outputs && output_size(o, *m) == 0;
      ps.push_back(empty ? fmt::format("double* /*{}*/", o.name) : fmt::format("double* {}", o.name));
    }
  for (const auto& e : sig.trailing) ps.push_back(fmt::format("{} {}", e.type, e.name));
  return ps;
}

std::vector<std::string> arguments(const Signature& sig) {
  std::vector<std::string> as;
  for (const auto& e : sig.leading) as.emplace_back(e.name);
  for (InputKind k : sig.inputs) as.emplace_back(name(k));
  if (sig.result != "double")
    for (const auto& o : sig.outputs) as.emplace_back(o.name);
  for (const auto& e : sig.trailing) as.emplace_back(e.name);
  return as;
}

// The name of the caller's scratch in a kernel's overload taking it: `work`, or `scratch` when
// the kernel already has a `work` (taylor_coefficients' series storage).
std::string_view scratch_name(const Signature& sig) {
  const bool has_work = std::any_of(sig.trailing.begin(), sig.trailing.end(),
                                    [](const auto& e) { return e.name == "work"; });
  return has_work ? "scratch" : "work";
}

}  // namespace

std::string detail::lending_overload(const Signature& sig, std::size_t size, bool device,
                                     std::string_view trailing) {
  std::vector<std::string> ps = parameters(sig, nullptr), args = arguments(sig);
  args.emplace_back(scratch_name(sig));
  if (!trailing.empty()) {  // "const double* pc": passed on by its name
    ps.emplace_back(trailing);
    args.emplace_back(trailing.substr(trailing.find_last_of(" *") + 1));
  }
  return fmt::format("{}{}\n  double {}[{}];\n{}\n}}\n", device ? detail::host_device : "",
                     wrap(fmt::format("{} {}(", sig.result, sig.name), ps, ") noexcept {"),
                     scratch_name(sig), size,
                     wrap(fmt::format("  {}{}(", sig.result == "void" ? "" : "return ", sig.name), args, ");"));
}

namespace {

// The array inputs a kernel's own guards already test: an input element that reaches the operand
// of an IsFinite guard through operations that keep an infinity or a NaN non-finite (±, ×, a
// numerator, √, |·|, sin, cos, tan, log, asin, acos) makes that guard fail whenever it is not
// finite, and the kernel then returns false and NaN as if it had tested the element first. A
// denominator, exp, atan, tanh, pow, atan2 and Select can make a finite value of one: not
// followed. (A lone free body's angular velocities reach its ω̇'s guards, its linear ones do not:
// it tests t, q and v up front, v whole.)
std::array<std::vector<bool>, input_kind_count> caught_by_guards(const Graph& g,
                                                                  std::span<const NodeId> guards) {
  std::vector<char> carries(g.size(), 0);  // a non-finite value here reaches a tested guard
  NodeId top = 0;
  for (NodeId x : guards)
    if (g[x].op == Op::IsFinite) {
      carries[g[x].arg[0]] = 1;
      top = std::max(top, g[x].arg[0]);
    }
  std::array<std::vector<bool>, input_kind_count> caught;
  for (NodeId id = top + 1; id-- > 0;) {  // arguments have smaller ids than their nodes
    if (!carries[id]) continue;
    const Node& n = g[id];
    switch (n.op) {
      case Op::Input: {
        std::vector<bool>& c = caught[n.arg[0]];
        if (c.size() <= n.arg[1]) c.resize(n.arg[1] + 1);
        c[n.arg[1]] = true;
        break;
      }
      case Op::Add: case Op::Sub: case Op::Mul:
        carries[n.arg[1]] = 1;
        [[fallthrough]];
      case Op::Neg: case Op::Div: case Op::Sqrt: case Op::Abs: case Op::Sin: case Op::Cos:
      case Op::Tan: case Op::Log: case Op::Asin: case Op::Acos:
        carries[n.arg[0]] = 1;
        break;
      default:
        break;
    }
  }
  return caught;
}

// Parameter-only work, done once per parameter set: the values a kernel reads that depend on p
// alone (the optimize stage's coefficients, products of parameters) come from an array that
// <kernel>_prepare fills, refreshed by <kernel>_parameters(p) only when p changes (one memcmp of
// np doubles per call). One array per kernel, so that a new p costs a kernel no more than its own
// parameter-only work; thread_local, so kernels stay reentrant across threads. A kernel whose
// parameter-only work is cheaper than that check (worth_caching) computes it inline instead.
struct ParameterCache {
  std::string accessor;        // <kernel>_parameters
  std::vector<NodeId> values;  // the cached nodes, in id order
  std::vector<int> index;      // node -> its place in values, or -1

  bool has(NodeId n) const { return n < index.size() && index[n] >= 0; }
};

// The cached nodes a kernel reads: walking from the roots, the first real-valued operation that
// depends on p alone on each path (booleans are walked through: guards stay in the kernel).
std::vector<NodeId> parameter_frontier(const Graph& g, std::span<const NodeId> roots) {
  std::vector<char> seen(g.size(), 0);
  std::vector<NodeId> stack(roots.begin(), roots.end()), out;
  while (!stack.empty()) {
    const NodeId n = stack.back();
    stack.pop_back();
    if (seen[n]) continue;
    seen[n] = 1;
    const Op op = g[n].op;
    if (arity(op) == 0) continue;
    if (!is_boolean(op) && g.parameter_only(n)) {
      out.push_back(n);
      continue;
    }
    for (int i = 0; i < arity(op); ++i) stack.push_back(g[n].arg[i]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The check costs a thread-local lookup and a memcmp of p: about as much as 16 operations plus
// one per 4 parameters. Below that, the cache would cost a call more than it saves.
bool worth_caching(const Graph& g, std::span<const NodeId> values, int np) {
  std::size_t operations = 0;
  for (NodeId n : cone(g, values)) operations += arity(g[n].op) > 0;
  return operations >= 16 + static_cast<std::size_t>(np) / 4;
}

// forward_dynamics or a derivative kernel in the looped form (emit.hpp): M's lower triangle, f,
// C, γ as the outputs of `kernel`, and where each goes in the array the dense routine reads
// (`size` doubles); a derivative kernel's right-hand sides as the outputs of `rhs`.
struct LoopedSystem {
  Kernel kernel;
  std::vector<int> positions;
  int size = 0;
  std::optional<Kernel> rhs = {};
};

// The row form's steps per function (RowSolve): GCC's time grows faster than their number in
// one function of vectorized loops; the humanoid's double support, 963 steps over 75
// right-hand sides, compiled in 90 s at -O3 as one function and in 7.8 s as parts of 100, which
// ran as fast (a step's rows are in memory either way).
constexpr std::size_t row_steps_per_part = 100;

// Writes one kernel's definition (and its parts, when it is split) into `out`; returns its
// operation count. The order and places of the statements are the kernel's program
// (eomgen/program.hpp); this class only prints it. A looped derivative kernel has two programs
// (M, f, C, γ; then the right-hand sides at the routine's q̈ and μ), written one after the other
// in blocks of their own; their parts are numbered on.
class KernelWriter {
  using Target = std::pair<std::string, int>;  // an output array and a position in it

 public:
  KernelWriter(const TracedModel& m, const Kernel& k, const ParameterCache* cache = nullptr)
      : m_(m), k_(k), sig_(signature(k.id)), cache_(cache) {}
  // <kernel>_prepare: the cached nodes as the outputs of a kernel of p alone; one frame's case of
  // a per-frame kernel (sig: <kernel>_<frame>, without f)
  KernelWriter(const TracedModel& m, const Kernel& k, const Signature& sig,
               const ParameterCache* cache = nullptr)
      : m_(m), k_(k), sig_(sig), cache_(cache) {}

  KernelWriter(const TracedModel& m, const LoopedSystem& looped, const ParameterCache* cache)
      : KernelWriter(m, looped.kernel, cache) {
    system_positions_ = looped.positions;
    system_size_ = looped.size;
    if (looped.rhs) {
      rhs_ = &*looped.rhs;
      rhs_sig_ = {sig_.name, "", "void", sig_.inputs, {{"rhs", Dim::outputs, Dim::one}}};
      rhs_sig_.inputs.push_back(InputKind::qdd);
      if (m.nc > 0) rhs_sig_.inputs.push_back(InputKind::mu);
    }
  }

  std::size_t write(Buffer& out) {
    const bool checked = sig_.result == "bool";
    const auto cache_index = cache_ ? std::span<const int>(cache_->index) : std::span<const int>();
    p_ = lower(m_.graph, k_, sig_, cache_index);
    if (rhs_) rhs_p_ = lower(m_.graph, *rhs_, rhs_sig_, cache_index);
    targets_[0] = targets(p_);
    if (rhs_p_) targets_[1] = rhs_targets();

    // A bool kernel first checks its inputs for finiteness, those its guards do not catch.
    std::vector<std::string> tests;
    const auto caught = checked ? caught_by_guards(m_.graph, k_.guards)
                                : std::array<std::vector<bool>, input_kind_count>{};
    const bool split = p_.split() || (rhs_p_ && rhs_p_->split());
    std::vector<bool> used(input_kind_count, split);  // with parts, every input is passed on
    for (const Program* p : programs())
      for (const Place& a : p->inputs) used[static_cast<int>(a.input)] = true;
    if (checked)
      for (InputKind k : sig_.inputs) {
        const int n = k == InputKind::u ? m_.nu : k == InputKind::p ? m_.np() : 1;
        if (n == 0) continue;  // u or p of size 0: may be null, never read
        used[static_cast<int>(k)] = true;
        if (k == InputKind::t)
          tests.emplace_back("nonfinite(t)");
        else if (k == InputKind::kd || k == InputKind::rho)  // ≥ 0 and finite
          tests.push_back(fmt::format("nonfinite({0}) | ({0} < 0)", name(k)));
        else if (k == InputKind::restitution)  // in [0, 1]
          tests.emplace_back("!(restitution >= 0 && restitution <= 1)");
        else  // the sizes nq, nv (of qd: nq without a free joint), nu, np, less what guards catch
          append_array_tests(tests, k, caught);
      }

    // Large kernels: the parts first, as functions that share the workspace w.
    const std::size_t parts = p_.parts + (rhs_p_ ? rhs_p_->parts : 0);
    write_parts(out, p_, sig_, 1, parts, checked);
    if (rhs_p_) write_parts(out, *rhs_p_, rhs_sig_, p_.parts + 1, parts, false);
    if (k_.row_solve) write_row_solve(out);

    const std::size_t counted = operation_count();
    fmt::format_to(std::back_inserter(out), "// {}: {} ({} operation{}", m_.name, sig_.name, counted,
                   counted == 1 ? "" : "s");
    if (looped())
      fmt::format_to(std::back_inserter(out), " and the looped dense solve of {} + {} unknowns",
                     m_.nv, m_.nc);
    if (rhs_)
      fmt::format_to(std::back_inserter(out), ", again for {} right-hand sides", directions());
    if (k_.row_solve)
      fmt::format_to(std::back_inserter(out), ", and {} more in {} row steps over {} right-hand sides",
                     row_operations(), k_.row_solve->steps.size(), k_.row_solve->directions);
    if (split) fmt::format_to(std::back_inserter(out), ", in {} parts", parts);
    out.append(std::string_view(")\n"));
    // A kernel with stack arrays (the parts' workspace, the looped solve's system) is written as
    // an overload taking them in `work` (<kernel>_workspace doubles, the caller's); the plain
    // signature lends it a stack array (lending_overload). A kernel that reads parameter-only
    // values takes them in `pc` (<kernel>_prepare's); the overloads without pc read them from the
    // thread_local cache (host only, write_cached_overloads).
    std::vector<std::string> ps = parameters(sig_, &used, &m_);
    if (workspace() > 0) ps.emplace_back("double* work");
    if (cached()) ps.emplace_back("const double* pc");
    out.append(detail::host_device);
    out.append(wrap(fmt::format("{} {}(", sig_.result, sig_.name), ps, ") noexcept {\n"));
    if (checked) {
      std::vector<std::string> fills;
      for (const auto& o : sig_.outputs)
        if (output_size(o, m_) > 0)
          fills.push_back(fmt::format("fill_nan({}, {});", o.name, length(o, m_)));
      fmt::format_to(std::back_inserter(out),
                     "  const auto fail = [&]() noexcept {{\n    {}\n    return false;\n  }};\n",
                     fmt::join(fills, "\n    "));
      out.append(wrap("  if (", tests, ") return fail();\n", " |"));  // integers: one branch
    }
    if (split) out.append(std::string_view("  double* const w = work;\n"));

    if (rhs_) {
      write_derivatives(out);
    } else if (k_.row_solve) {
      write_by_rows(out);
    } else {
      if (looped())
        fmt::format_to(std::back_inserter(out), "  double* const system = work + {};\n", system_at());
      write_statements(out, p_, sig_, 1);
      if (looped()) {
        write_outputs(out, p_, "system", p_.outputs, system_positions_);
        fmt::format_to(std::back_inserter(out),
                       "  if (!solve_dense_system<{}, {}>(system, qdd)) return fail();\n"
                       "  return true;\n",
                       m_.nv, m_.nc);
      } else if (sig_.result == "double") {
        fmt::format_to(std::back_inserter(out), "  return {};\n", operand(p_, p_.outputs.at(0)));
      } else {
        const std::vector<std::size_t> counts = output_counts(p_);
        std::size_t at = 0;
        for (std::size_t o = 0; o < counts.size(); at += counts[o], ++o) {
          std::vector<int> positions(counts[o]);
          std::iota(positions.begin(), positions.end(), 0);
          write_outputs(out, p_, sig_.outputs[o].name, std::span(p_.outputs).subspan(at, counts[o]), positions);
        }
        if (checked) out.append(std::string_view("  return true;\n"));
      }
    }
    out.append(std::string_view("}\n"));
    if (cached())
      write_cached_overloads(out);
    else if (workspace() > 0)
      out.append(detail::lending_overload(sig_, workspace(), true));
    return counted;
  }

  // Whether the kernel reads the parameter cache (call after write).
  bool cached() const { return p_.reads_cache || (rhs_p_ && rhs_p_->reads_cache); }

  // "nonfinite(q, nq)" for an input array, none if the guards catch all its elements: the whole
  // array, a few vector operations (nonfinite), costs less than the runs the guards leave. p
  // stays whole where the kernel reads the parameter cache: there the guards' paths from p may
  // pass through pc, which the caller fills.
  void append_array_tests(std::vector<std::string>& tests, InputKind k,
                          const std::array<std::vector<bool>, input_kind_count>& caught) const {
    const int n = k == InputKind::q ? m_.nq : k == InputKind::qd ? m_.nv : k == InputKind::u ? m_.nu : m_.np();
    const std::vector<bool>& c = caught[static_cast<int>(k)];
    bool all = !(k == InputKind::p && cached()) && std::ssize(c) >= n;
    for (int i = 0; i < n && all; ++i) all = c[i];
    if (!all)
      tests.push_back(fmt::format("nonfinite({}, {})", name(k),
                                  k == InputKind::qd ? dim_name(Dim::nv, m_) : fmt::format("n{}", name(k))));
  }

  // The overloads of a kernel that reads parameter-only values (its definition takes them in
  // pc): with pc and without work (lending work, for any device); without pc, taking them from
  // the thread_local cache (host only): <kernel>(..., work) and the plain signature.
  void write_cached_overloads(Buffer& out) const {
    const bool ws = workspace() > 0;
    if (ws) out.append(detail::lending_overload(sig_, workspace(), true, "const double* pc"));
    std::vector<std::string> ps = parameters(sig_, nullptr), as = arguments(sig_);
    if (ws) ps.emplace_back("double* work"), as.emplace_back("work");
    as.emplace_back("pc");
    fmt::format_to(std::back_inserter(out), "{}\n  const double* const pc = {}(p);\n{}\n}}\n",
                   wrap(fmt::format("{} {}(", sig_.result, sig_.name), ps, ") noexcept {"),
                   cache_->accessor,
                   wrap(fmt::format("  {}{}(", sig_.result == "void" ? "" : "return ", sig_.name), as, ");"));
    if (ws) out.append(detail::lending_overload(sig_, workspace()));
  }

  // The statements, and the sines and cosines of sincos_n's call (not the row solve's loops:
  // the count sizes the compile, tracer.cpp's long_compile).
  std::size_t operation_count() const {
    std::size_t n = 0;
    for (const Program* p : programs()) n += p->code.size() + 2 * p->angles.size();
    return n;
  }
  // The row solve's arithmetic, counted as the straight-line form counts it: a multiply-add is
  // two operations per right-hand side, a scaling one.
  std::size_t row_operations() const {
    if (!k_.row_solve) return 0;
    std::size_t n = 0;
    for (const RowSolve::Step& step : k_.row_solve->steps)
      n += (step.kind == RowSolve::Step::Kind::add ? 2 : 1) * static_cast<std::size_t>(k_.row_solve->count(step));
    return n;
  }

  // The doubles of work the kernel's overload with `double* work` takes (0: it has none): the
  // programs' slots (the second reuses the first's), the dense routine's array, q̈ and the
  // right-hand sides.
  int workspace() const {
    if (k_.row_solve)  // (7 to spare: the rows start a cache line, aligned_rows)
      return rows_at() + k_.row_solve->factors + 7 + k_.row_solve->rows * k_.row_solve->ld();
    if (!looped()) return p_.slots + trig_slots(p_);
    return system_at() + system_size_ + (rhs_ ? m_.nv + (m_.nv + m_.nc) * directions() : 0);
  }

 private:
  bool looped() const { return system_size_ > 0; }
  // Where the row form's factors, then its right-hand sides, start in work.
  int rows_at() const { return p_.slots + trig_slots(p_); }
  std::vector<const Program*> programs() const {
    std::vector<const Program*> ps{&p_};
    if (rhs_p_) ps.push_back(&*rhs_p_);
    return ps;
  }
  // Where the dense routine's array starts in work: after every program's slots.
  int system_at() const {
    int at = 0;
    for (const Program* p : programs()) at = std::max(at, p->slots + trig_slots(*p));
    return at;
  }
  // The right-hand sides of a looped derivative kernel: one per column of its outputs.
  int directions() const {
    int n = 0;
    for (const auto& o : sig_.outputs) n += size(o.cols, m_);
    return n;
  }
  // Where each output of the main program goes: a position in an output array of the signature
  // (in the looped form, the dense routine's array `system`).
  std::vector<Target> targets(const Program& p) const {
    std::vector<Target> t;
    if (k_.row_solve) {
      const RowSolve& r = *k_.row_solve;
      for (int i = 0; i < r.factors; ++i) t.emplace_back("factors", i);
      for (int d = 0; d < r.directions; ++d)
        for (int i = 0; i < r.rows; ++i) t.emplace_back("rhs", r.ld() * i + d);
      if (t.size() != p.outputs.size())
        throw std::logic_error(fmt::format("eomgen: kernel {} has {} outputs, its row solve {}", sig_.name,
                                           p.outputs.size(), t.size()));
    } else if (looped()) {
      for (int at : system_positions_) t.emplace_back("system", at);
    } else if (sig_.result != "double") {
      const std::vector<std::size_t> counts = output_counts(p);
      for (std::size_t o = 0; o < counts.size(); ++o)
        for (std::size_t i = 0; i < counts[o]; ++i) t.emplace_back(sig_.outputs[o].name, static_cast<int>(i));
    }
    return t;
  }
  // The right-hand sides' program writes them into `rhs` by rows, the directions across
  // (solve_dense_rows): value i of direction d at i · directions + d.
  std::vector<int> rhs_positions() const {
    const int rows = m_.nv + m_.nc, columns = directions();
    std::vector<int> at;
    for (int d = 0; d < columns; ++d)
      for (int i = 0; i < rows; ++i) at.push_back(i * columns + d);
    return at;
  }
  std::vector<Target> rhs_targets() const {
    std::vector<Target> t;
    for (int at : rhs_positions()) t.emplace_back("rhs", at);
    return t;
  }
  const std::vector<Target>& targets_of(const Program& p) const { return &p == &p_ ? targets_[0] : targets_[1]; }

  // The output arrays instructions [begin, end) write or read, in the order of the outputs.
  std::vector<std::string> arrays_in(const Program& p, std::size_t begin, std::size_t end) const {
    std::vector<char> touched(p.outputs.size(), 0);
    for (std::size_t i = begin; i < end; ++i) {
      const Instruction& in = p.code[i];
      if (in.to.kind == Place::Kind::output) touched[in.to.index] = 1;
      for (int k = 0; k < arity(in.op); ++k)
        if (in.from[k].kind == Place::Kind::output) touched[in.from[k].index] = 1;
    }
    for (const Copy& c : p.copies)
      if (c.after >= begin && c.after < end) touched[c.output] = 1;
    std::vector<std::string> arrays;
    const std::vector<Target>& t = targets_of(p);
    for (std::size_t k = 0; k < t.size(); ++k)
      if (touched[k] && std::find(arrays.begin(), arrays.end(), t[k].first) == arrays.end())
        arrays.push_back(t[k].first);
    return arrays;
  }

  // With parts, the sines and cosines live in the workspace after the parts' slots.
  static int trig_slots(const Program& p) { return p.split() ? 2 * static_cast<int>(p.angles.size()) : 0; }

  // Each output of the signature: how many of the program's outputs it takes.
  std::vector<std::size_t> output_counts(const Program& p) const {
    std::vector<std::size_t> counts;
    for (const auto& o : sig_.outputs)
      counts.push_back(o.rows == Dim::outputs ? p.outputs.size() : static_cast<std::size_t>(output_size(o, m_)));
    if (const std::size_t total = std::accumulate(counts.begin(), counts.end(), std::size_t{0});
        total != p.outputs.size())
      throw std::logic_error(fmt::format("eomgen: kernel {} has {} outputs, its signature {}",
                                         sig_.name, p.outputs.size(), total));
    return counts;
  }

  // A split program's parts, numbered from `first` of `total`.
  void write_parts(Buffer& out, const Program& p, const Signature& sig, std::size_t first,
                   std::size_t total, bool checked) const {
    if (!p.split()) return;
    const std::size_t ops = p.code.size();
    for (std::size_t k = 0; k < p.parts; ++k) {
      const std::size_t begin = k * part_size, end = std::min(ops, begin + part_size);
      const std::vector<bool> reads = used_in(p, begin, end);
      fmt::format_to(std::back_inserter(out), "// {}: {}, part {} of {}\n", m_.name, sig_.name,
                     first + k, total);
      std::vector<std::string> ps = parameters(sig, &reads, &m_, false);
      if (reads_cache(p, begin, end)) ps.emplace_back("const double* pc");
      for (const std::string& a : arrays_in(p, begin, end)) ps.push_back("double* " + a);
      ps.emplace_back(touches_workspace(p, begin, end) ? "double* w" : "double* /*w*/");
      out.append(detail::host_device);
      out.append(wrap(fmt::format("static {} {}_part{}(", checked ? "bool" : "void", sig_.name, first + k),
                      ps, ") noexcept {\n"));
      body(out, p, begin, end, "return false;");
      if (checked) out.append(std::string_view("  return true;\n"));
      out.append(std::string_view("}\n\n"));
    }
  }

  // A program's statements in the kernel: the sines and cosines, then its body or its parts'
  // calls (numbered from `first`).
  void write_statements(Buffer& out, const Program& p, const Signature& sig, std::size_t first) const {
    const bool checked = sig.result == "bool";
    write_trig(out, p);
    if (!p.split()) {
      body(out, p, 0, p.code.size(), "return fail();");
      return;
    }
    for (std::size_t k = 0; k < p.parts; ++k) {
      const std::size_t begin = k * part_size, end = std::min(p.code.size(), begin + part_size);
      std::vector<std::string> args;
      for (InputKind i : sig.inputs) args.emplace_back(name(i));
      if (reads_cache(p, begin, end)) args.emplace_back("pc");
      for (std::string& a : arrays_in(p, begin, end)) args.push_back(std::move(a));
      args.emplace_back("w");
      if (checked)
        out.append(wrap(fmt::format("  if (!{}_part{}(", sig_.name, first + k), args, ")) return fail();\n"));
      else
        out.append(wrap(fmt::format("  {}_part{}(", sig_.name, first + k), args, ");\n"));
    }
  }

  // A looped derivative kernel: M, f, C, γ, the dense routine, the right-hand sides at its q̈ and
  // μ (by rows: row i holds value i of every direction), and their solves into the outputs
  // (column k of the concatenated outputs from right-hand side k).
  void write_derivatives(Buffer& out) const {
    const int n = m_.nv, nc = m_.nc;
    fmt::format_to(std::back_inserter(out),
                   "  double* const system = work + {};\n"
                   "  double* const qdd = system + {};\n"
                   "  double* const rhs = qdd + {};\n"
                   "  {{  // M, f, C, γ\n",
                   system_at(), system_size_, n);
    Buffer block;
    write_statements(block, p_, sig_, 1);
    write_outputs(block, p_, "system", p_.outputs, system_positions_);
    indented(out, block);
    fmt::format_to(std::back_inserter(out),
                   "  }}\n  if (!solve_dense_system<{}, {}>(system, qdd)) return fail();\n", n, nc);
    const bool reads_mu = std::any_of(rhs_p_->inputs.begin(), rhs_p_->inputs.end(),
                                      [](const Place& a) { return a.input == InputKind::mu; });
    if (reads_mu)
      fmt::format_to(std::back_inserter(out),
                     "  const double* const mu = system + {};  // the dense routine's μ\n",
                     dense::DenseLayout(n, nc).mu);
    fmt::format_to(std::back_inserter(out), "  {{  // the right-hand sides, {} per direction, by rows\n", n + nc);
    block.clear();
    write_statements(block, *rhs_p_, rhs_sig_, p_.parts + 1);
    const std::vector<int> positions = rhs_positions();
    if (positions.size() != rhs_p_->outputs.size())
      throw std::logic_error(fmt::format("eomgen: kernel {} has {} right-hand side values, not {}",
                                         sig_.name, rhs_p_->outputs.size(), positions.size()));
    write_outputs(block, *rhs_p_, "rhs", rhs_p_->outputs, positions);
    indented(out, block);
    out.append(std::string_view("  }\n"));
    int column = 0;
    for (const auto& o : sig_.outputs) {
      const int count = size(o.cols, m_);
      if (count > 0)
        fmt::format_to(std::back_inserter(out), "  solve_dense_rows<{}, {}, {}>(system, rhs{}, {}, {});\n",
                       n, nc, directions(), column > 0 ? fmt::format(" + {}", column) : "", count, o.name);
      column += count;
    }
    out.append(std::string_view("  return true;\n"));
  }

  // The row form (RowSolve): the factors and the right-hand sides into work, the steps (the
  // function write_row_solve wrote), and the outputs out of the solved rows.
  void write_by_rows(Buffer& out) const {
    const RowSolve& r = *k_.row_solve;
    fmt::format_to(std::back_inserter(out),
                   "  double* const factors = work + {};\n"
                   "  double* const rhs = aligned_rows(factors + {});  // {} rows of {} right-hand sides\n",
                   rows_at(), r.factors, r.rows, r.directions);
    // The right-hand sides' structural zeros (most of a humanoid's: a direction moves few
    // velocities' forces) by one vectorized fill of the block first, rather than one scalar store
    // each, a row apart, where the whole block costs fewer stores.
    const auto zero = [&](std::size_t i) {
      return p_.outputs[i].kind == Place::Kind::constant && p_.outputs[i].value == 0.0 && targets_[0][i].first == "rhs";
    };
    std::size_t zeros = 0;
    for (std::size_t i = 0; i < p_.outputs.size(); ++i) zeros += zero(i);
    const std::size_t block = static_cast<std::size_t>(r.rows) * r.ld();
    const bool fill = 8 * zeros >= block;
    if (fill) fmt::format_to(std::back_inserter(out), "  for (int i = 0; i < {}; ++i) rhs[i] = 0.0;\n", block);
    write_statements(out, p_, sig_, 1);
    for (std::size_t i = 0; i < p_.outputs.size(); ++i)  // but those a split kernel's parts wrote
      if (p_.outputs[i].kind != Place::Kind::output && !(fill && zero(i)))
        fmt::format_to(std::back_inserter(out), "  {}[{}] = {};\n", targets_[0][i].first, targets_[0][i].second,
                       operand(p_, p_.outputs[i]));
    for (std::size_t part = 0; part < row_parts(); ++part)
      fmt::format_to(std::back_inserter(out), "  {}_rows{}(factors, rhs);\n", sig_.name, part + 1);
    // The velocity outputs (nv rows), then the force outputs (negated), each a block of columns.
    const std::size_t half = sig_.outputs.size() / 2;
    int column = 0;
    for (std::size_t o = 0; o < sig_.outputs.size(); ++o) {
      if (o == half) column = 0;
      const bool force = o >= half;
      const int count = size(sig_.outputs[o].cols, m_), rows = force ? r.force_rows : r.nv;
      const int first = force ? r.force_from : r.velocity_row(0), step = force || !r.reversed ? r.ld() : -r.ld();
      // Runs of solved columns copied out of the rows; the zero directions' columns zeroed.
      for (int a = column; a < column + count;) {
        const bool zero = std::binary_search(r.zero.begin(), r.zero.end(), a);
        int b = a + 1;
        while (b < column + count && std::binary_search(r.zero.begin(), r.zero.end(), b) == zero) ++b;
        if (zero)
          fmt::format_to(std::back_inserter(out), "  for (int i = 0; i < {}; ++i) {}[{} + i] = 0.0;\n", rows * (b - a),
                         sig_.outputs[o].name, rows * (a - column));
        else
          fmt::format_to(std::back_inserter(out), "  columns_of_rows<{}, {}>(rhs + {}, {}, {}, {}{});\n", rows, step,
                         r.ld() * first + r.column(a), b - a, force ? "-1.0" : "1.0", sig_.outputs[o].name,
                         a > column ? fmt::format(" + {}", rows * (a - column)) : "");
        a = b;
      }
      if (!force && r.identity_from >= column && r.identity_from < column + count && count > 0) {
        if (r.identity_from != column)
          throw std::logic_error("eomgen: the identity of " + std::string(sig_.name) + " splits an output");
        fmt::format_to(std::back_inserter(out), "  for (int i = 0; i < {0}; ++i) {1}[i + {0} * i] += 1.0;\n",
                       rows, sig_.outputs[o].name);
      }
      column += count;
    }
    out.append(std::string_view("  return true;\n"));
  }

  // The row form's solve in functions of their own, row_steps_per_part steps each: the steps
  // straight-line, each a loop over the right-hand sides that the compiler vectorizes (out of
  // line: inlined into a kernel of thousands of statements, GCC 12 may leave loops scalar;
  // dense_solve.inc).
  void write_row_solve(Buffer& out) const {
    const RowSolve& r = *k_.row_solve;
    for (std::size_t part = 0; part < row_parts(); ++part) {
      fmt::format_to(std::back_inserter(out),
                     "// {}: {}, its right-hand sides' solve by rows, part {} of {}\n"
                     "[[gnu::noinline]] EOM_HOST_DEVICE static void {}_rows{}(const double* __restrict f,\n"
                     "                                                   double* __restrict b) noexcept {{\n",
                     m_.name, sig_.name, part + 1, row_parts(), sig_.name, part + 1);
      const std::size_t end = std::min(r.steps.size(), (part + 1) * row_steps_per_part);
      for (std::size_t i = part * row_steps_per_part; i < end; ++i) {
        const RowSolve::Step& step = r.steps[i];
        if (step.kind == RowSolve::Step::Kind::scale)
          fmt::format_to(std::back_inserter(out), "  scale_row({}, f[{}], b + {});\n", r.count(step), step.factor,
                         r.ld() * step.to);
        else
          fmt::format_to(std::back_inserter(out), "  add_scaled({}, {}f[{}], b + {}, b + {});\n", r.count(step),
                         step.negate ? "-" : "", step.factor, r.ld() * step.from, r.ld() * step.to);
      }
      out.append(std::string_view("}\n\n"));
    }
  }
  std::size_t row_parts() const {
    return std::max<std::size_t>(1, (k_.row_solve->steps.size() + row_steps_per_part - 1) / row_steps_per_part);
  }

  // The lines of a block's statements, two spaces further in.
  static void indented(Buffer& out, const Buffer& block) {
    const std::string_view text(block.data(), block.size());
    for (std::size_t at = 0; at < text.size();) {
      const std::size_t end = std::min(text.find('\n', at), text.size() - 1) + 1;
      out.append(std::string_view("  "));
      out.append(text.substr(at, end - at));
      at = end;
    }
  }

  // sc = [sin of each angle, cos of each angle] by one call (the helper of trig_helper_text).
  void write_trig(Buffer& out, const Program& p) const {
    if (p.angles.empty()) return;
    const std::size_t k = p.angles.size();
    std::vector<std::string> xs;
    for (const Place& a : p.angles) xs.push_back(operand(p, a));
    if (p.split())
      fmt::format_to(std::back_inserter(out), "  double* const sc = w + {};\n", p.slots);
    else
      fmt::format_to(std::back_inserter(out), "  double sc[{}];\n", 2 * k);
    out.append(wrap(fmt::format("  const double angles[{}] = {{", k), xs, "};\n"));
    fmt::format_to(std::back_inserter(out), "  sincos_n(angles, sc, sc + {0}, {0});\n", k);
  }

  // array[positions[i]] = values[i], but for the outputs a split kernel's parts have written.
  void write_outputs(Buffer& out, const Program& p, std::string_view array, std::span<const Place> values,
                     std::span<const int> positions) const {
    for (std::size_t i = 0; i < values.size(); ++i)
      if (values[i].kind != Place::Kind::output)
        fmt::format_to(std::back_inserter(out), "  {}[{}] = {};\n", array, positions[i], operand(p, values[i]));
  }
  // Which inputs instructions [begin, end) read, with the angles whose trig_at they hold.
  static std::vector<bool> used_in(const Program& p, std::size_t begin, std::size_t end) {
    std::vector<bool> used(input_kind_count, false);
    for (std::size_t i = begin; i < end; ++i)
      for (int k = 0; k < arity(p.code[i].op); ++k)
        if (const Place& a = p.code[i].from[k]; a.kind == Place::Kind::input) used[static_cast<int>(a.input)] = true;
    const std::vector<std::size_t> first = trig_first_uses(p);
    for (std::size_t j = 0; j < first.size(); ++j)
      if (first[j] >= begin && (first[j] < end || (end == p.code.size() && first[j] == end)))
        used[static_cast<int>(p.angles[j].input)] = true;
    return used;
  }
  // The instruction that first reads each angle's sine or cosine (the instruction count if only
  // an output does): its trig_at goes right before it.
  static std::vector<std::size_t> trig_first_uses(const Program& p) {
    const std::size_t k = p.angles.size();
    std::vector<std::size_t> first(k, p.code.size());
    for (std::size_t i = 0; i < p.code.size() && k > 0; ++i)
      for (int a = 0; a < arity(p.code[i].op); ++a)
        if (const Place& x = p.code[i].from[a]; x.kind == Place::Kind::trig) {
          std::size_t& f = first[static_cast<std::size_t>(x.index) % k];
          f = std::min(f, i);
        }
    return first;
  }

  // Whether instructions [begin, end) of a split program read or write w (its slots, or the sines
  // and cosines kept there); a part of the results' guards alone does not.
  static bool touches_workspace(const Program& p, std::size_t begin, std::size_t end) {
    const auto in_w = [](const Place& a) { return a.kind == Place::Kind::workspace || a.kind == Place::Kind::trig; };
    for (std::size_t i = begin; i < end; ++i) {
      if (in_w(p.code[i].to)) return true;
      for (int k = 0; k < arity(p.code[i].op); ++k)
        if (in_w(p.code[i].from[k])) return true;
    }
    return false;
  }

  // Whether instructions [begin, end) read the parameter cache.
  static bool reads_cache(const Program& p, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      for (int k = 0; k < arity(p.code[i].op); ++k)
        if (p.code[i].from[k].kind == Place::Kind::cached) return true;
    return false;
  }

  void body(Buffer& out, const Program& p, std::size_t begin, std::size_t end, std::string_view fail) const {
    auto copy = std::lower_bound(p.copies.begin(), p.copies.end(), begin,
                                 [](const Copy& c, std::size_t i) { return c.after < i; });
    const std::size_t k = p.angles.size();
    const std::vector<std::size_t> first = trig_first_uses(p);
    auto trig_at = [&](std::size_t i) {  // those first read by instruction i
      auto sc = [&](std::size_t j) {
        return p.split() ? fmt::format("w[{}]", p.slots + static_cast<int>(j)) : fmt::format("sc[{}]", j);
      };
      for (std::size_t j = 0; j < k; ++j)
        if (first[j] == i)
          fmt::format_to(std::back_inserter(out), "  trig_at({}, {}, {});\n", operand(p, p.angles[j]), sc(j),
                         sc(k + j));
    };
    // Consecutive finiteness guards (a kernel's results) share one test, up to 16: their carries
    // OR-ed, one branch (no angle first read by the next; a guard has no value, so no output copy
    // follows one).
    auto joins = [&](std::size_t i) {
      return i + 1 < end && p.code[i + 1].guard && p.code[i + 1].op == Op::IsFinite &&
             std::find(first.begin(), first.end(), i + 1) == first.end();
    };
    for (std::size_t i = begin; i < end; ++i) {
      const Instruction& in = p.code[i];
      const int n = arity(in.op);
      trig_at(i);
      if (in.guard && in.op == Op::IsFinite && joins(i)) {
        std::vector<std::string> carries{fmt::format("nonfinite_carry({})", operand(p, in.from[0]))};
        for (; carries.size() < 16 && joins(i); ++i)
          carries.push_back(fmt::format("nonfinite_carry({})", operand(p, p.code[i + 1].from[0])));
        out.append(wrap("  if ((", carries, fmt::format(") >> 63) {}\n", fail), " |"));
        continue;
      }
      ops::Text args[3];
      for (int a = 0; a < n; ++a) args[a].s = operand(p, in.from[a]);
      const std::string e = ops::print(in.op, std::span<const ops::Text>(args, n)).s;
      if (in.guard)
        fmt::format_to(std::back_inserter(out), "  if (!{}) {}\n", e, fail);
      else if (in.to.kind == Place::Kind::workspace)  // a boolean is stored as 1.0 or 0.0
        fmt::format_to(std::back_inserter(out), "  w[{}] = {};\n", in.to.index, e);
      else if (in.to.kind == Place::Kind::output)
        fmt::format_to(std::back_inserter(out), "  {} = {};\n", operand(p, in.to), e);
      else
        fmt::format_to(std::back_inserter(out), "  const {} v{} = {};\n", in.to.boolean ? "bool" : "double",
                       in.to.index, e);
      for (; copy != p.copies.end() && copy->after == i; ++copy)
        fmt::format_to(std::back_inserter(out), "  {} = {};\n",
                       operand(p, p.outputs[static_cast<std::size_t>(copy->output)]), operand(p, in.to));
    }
    if (end == p.code.size()) trig_at(end);  // angles only an output reads
  }

  std::string operand(const Program& p, const Place& at) const {
    switch (at.kind) {
      case Place::Kind::constant: return literal(at.value);
      case Place::Kind::input:
        return is_scalar(at.input) ? std::string(name(at.input)) : fmt::format("{}[{}]", name(at.input), at.index);
      case Place::Kind::cached: return fmt::format("pc[{}]", at.index);
      case Place::Kind::trig:
        return p.split() ? fmt::format("w[{}]", p.slots + at.index) : fmt::format("sc[{}]", at.index);
      case Place::Kind::local: return fmt::format("v{}", at.index);
      case Place::Kind::workspace:
        return at.boolean ? fmt::format("(w[{}] != 0.0)", at.index) : fmt::format("w[{}]", at.index);
      case Place::Kind::output: {
        const Target& t = targets_of(p).at(static_cast<std::size_t>(at.index));
        return fmt::format("{}[{}]", t.first, t.second);
      }
    }
    return {};
  }

  const TracedModel& m_;
  const Kernel& k_;
  const Signature& sig_;
  const ParameterCache* cache_ = nullptr;
  std::vector<int> system_positions_;
  int system_size_ = 0;
  const Kernel* rhs_ = nullptr;
  Signature rhs_sig_;
  Program p_;
  std::optional<Program> rhs_p_;
  std::vector<Target> targets_[2];  // p_'s, rhs_p_'s
};

// sin and cos of a kernel's angles (its inputs' sines and cosines) by one call, written once per
// source. By default an inline routine (fdlibm's reduction by pi/2 in three parts and its
// polynomials on [-pi/4, pi/4]), branch-free so that the loop over the angles vectorizes, and
// without contracted products so that vector and scalar code get the same bits (the batch
// kernel's lanes call it too): within 0.78 ulp measured (std::sin and std::cos are correctly
// rounded in practice) and much cheaper than a sincos call per angle (MuJoCo's humanoid's inverse
// dynamics: 0.77-0.79x its time with the calls; docs/benchmarks/pinocchio.md); |x| >= 1e5,
// infinities and NaN by std::sin and std::cos, all of them so under -ffast-math and in a CUDA
// source (both nvcc passes: std::sin and std::cos where first read, trig_at). EOM_LIBMVEC
// (x86-64 glibc) takes them from glibc's vector math library instead, 4 lanes under AVX2 (else
// 2), within 4 ulp.
constexpr std::string_view trig_helper_text = R"(
#if defined(EOM_LIBMVEC) && defined(__x86_64__) && defined(__GLIBC__) && \
    (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 22)) && !defined(__CUDA_ARCH__)
namespace libmvec {  // glibc's functions, so declared with external linkage
#if defined(__AVX2__)
constexpr int width = 4;
typedef double vector __attribute__((vector_size(4 * sizeof(double))));
vector sin(vector) noexcept __asm__("_ZGVdN4v_sin");
vector cos(vector) noexcept __asm__("_ZGVdN4v_cos");
#else
constexpr int width = 2;
typedef double vector __attribute__((vector_size(2 * sizeof(double))));
vector sin(vector) noexcept __asm__("_ZGVbN2v_sin");
vector cos(vector) noexcept __asm__("_ZGVbN2v_cos");
#endif
}  // namespace libmvec
namespace {
inline void sincos_n(const double* x, double* s, double* c, int n) noexcept {
  for (int i = 0; i < n; i += libmvec::width) {
    const int m = n - i < libmvec::width ? n - i : libmvec::width;
    libmvec::vector a = {};
    __builtin_memcpy(&a, x + i, m * sizeof(double));
    const libmvec::vector sa = libmvec::sin(a), ca = libmvec::cos(a);
    __builtin_memcpy(s + i, &sa, m * sizeof(double));
    __builtin_memcpy(c + i, &ca, m * sizeof(double));
  }
}
inline void trig_at(double, double&, double&) noexcept {}
}  // namespace
#elif !defined(__CUDACC__) && !defined(__FAST_MATH__)  // (its rounding needs IEEE arithmetic)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")
#endif
namespace {
// sin and cos of x[0..n): each angle less k pi/2 (k the nearest integer to 2x/pi, pi/2 in three
// parts so that the remainder y0 + y1 keeps its bits), fdlibm's sin and cos of it (its
// __kernel_sin and __kernel_cos), swapped and signed by k's quadrant.
EOM_HOST_DEVICE
inline void sincos_n(const double* x, double* s, double* c, int n) noexcept {
#if defined(__clang__)
#pragma clang fp contract(off)
#endif
  for (int i = 0; i < n; ++i) {
    const double a = std::fabs(x[i]) < 1e5 ? x[i] : 0.0;
    const double shift = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
    const double k = (a * 6.36619772367581382433e-01 + shift) - shift;
    const double t = a - k * 1.57079632673412561417e+00;  // exact: 33 bits times |k| < 2^17
    const double w = k * 6.07710050630396597660e-11;
    const double r = t - w;
    const double w2 = k * 2.02226624879595063154e-21 - ((t - r) - w);
    const double y0 = r - w2, y1 = (r - y0) - w2;
    const double z = y0 * y0, v = z * y0;
    const double ps = 8.33333333332248946124e-03 +
                      z * (-1.98412698298579493134e-04 +
                           z * (2.75573137070700676789e-06 +
                                z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)));
    const double sn = y0 - ((z * (0.5 * y1 - v * ps) - y1) - v * -1.66666666666666324348e-01);
    const double pc =
        z * (4.16666666666666019037e-02 +
             z * (-1.38888888888741095749e-03 +
                  z * (2.48015872894767294178e-05 +
                       z * (-2.75573143513906633035e-07 +
                            z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
    const double hz = 0.5 * z, wc = 1.0 - hz;
    const double cs = wc + (((1.0 - wc) - hz) + (z * pc - y0 * y1));
    const int q = static_cast<int>(k) & 3;
    const double sq = (q & 1) ? cs : sn, cq = (q & 1) ? sn : cs;
    s[i] = (q & 2) ? -sq : sq;
    c[i] = ((q + 1) & 2) ? -cq : cq;
  }
  for (int i = 0; i < n; ++i)
    if (!(std::fabs(x[i]) < 1e5)) {
      s[i] = std::sin(x[i]);
      c[i] = std::cos(x[i]);
    }
}
EOM_HOST_DEVICE
inline void trig_at(double, double&, double&) noexcept {}
}  // namespace
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif
#else
namespace {
// Each angle's sine and cosine where first used instead (trig_at: one sincos call), so that
// the calls overlap the arithmetic around them rather than run back to back.
EOM_HOST_DEVICE
inline void sincos_n(const double*, double*, double*, int) noexcept {}
EOM_HOST_DEVICE
inline void trig_at(double x, double& s, double& c) noexcept {
  s = std::sin(x);
  c = std::cos(x);
}
}  // namespace
#endif
namespace {
// One angle's sine or cosine as above (sincos_n or trig_at computes it): Taylor mode's order 0
// (unused without a Taylor kernel).
[[maybe_unused]] inline double sin_of_angle(double x) noexcept {
  double s = 0.0, c = 0.0;
  sincos_n(&x, &s, &c, 1);
  trig_at(x, s, c);
  return s;
}
[[maybe_unused]] inline double cos_of_angle(double x) noexcept {
  double s = 0.0, c = 0.0;
  sincos_n(&x, &s, &c, 1);
  trig_at(x, s, c);
  return c;
}
}  // namespace
)";

LoopedSystem looped_system(const TracedModel& m, const Kernel& k) {
  LoopedSystem out{Kernel{k.id, {}, {}}, {}, dense::DenseLayout(m.nv, m.nc).size};
  if (k.id != KernelId::forward_dynamics) out.rhs = Kernel{k.id, k.outputs, {}};
  for (auto [node, position] : dense_system_entries(k.system.value())) {
    out.kernel.outputs.push_back(node);
    out.positions.push_back(position);
  }
  return out;
}

// A kernel's parameter cache: <kernel>_prepare(p, v) computes the cached values (any device:
// the kernel's overload taking pc reads them), and <kernel>_parameters(p) returns them for p
// from a thread_local array, recomputed only when p changes (host only).
void write_parameter_cache(const TracedModel& m, const Signature& kernel, const ParameterCache& cache,
                           Buffer& out) {
  const std::string name = fmt::format("{}_prepare", kernel.name);
  const Signature prepare{name, "", "void", {InputKind::p}, {{"v", Dim::outputs, Dim::one}}};
  const Kernel values{KernelId::mass_matrix, cache.values, {}};
  fmt::format_to(std::back_inserter(out),
                 "// {}'s parameter-only values (pc[]), once per parameter set.\n", kernel.name);
  KernelWriter(m, values, prepare).write(out);
  fmt::format_to(std::back_inserter(out),
                 "namespace {{\n\n"
                 "const double* {0}(const double* p) noexcept {{\n"
                 "  struct Cache {{\n"
                 "    double p[np];\n"
                 "    double v[{1}];\n"
                 "    bool ready;\n"
                 "  }};\n"
                 "  thread_local Cache cache{{}};\n"
                 "  if (!cache.ready || std::memcmp(cache.p, p, sizeof cache.p) != 0) {{\n"
                 "    {2}(p, cache.v);\n"
                 "    std::memcpy(cache.p, p, sizeof cache.p);\n"
                 "    cache.ready = true;\n"
                 "  }}\n"
                 "  return cache.v;\n"
                 "}}\n\n}}  // namespace\n\n",
                 cache.accessor, cache.values.size(), name);
}

// The name of case i of a per-case kernel: its frame's, or its contact set's.
std::string case_name(const TracedModel& m, KernelId id, std::size_t i) {
  return per_frame(id) ? m.frames.at(i).name : m.contact_sets.at(i).name;
}

// One function of a per-case kernel: case `index`'s (<kernel>_<index>, or <kernel>_<index>_exact
// for a contact value kernel's twin with ρ folded to 0, Kernel::exact), the size of its own
// parameter cache (0: none), or the earlier function whose cache it reads (the same values).
struct CaseFunction {
  int index = 0;
  bool exact = false;
  int cache = 0;
  std::optional<std::size_t> shares = {};
};

// A per-case kernel: the switch over its index (f: frames, s: contact sets) that calls case i's
// function (<kernel>_<i>; where the case has an exact twin, that for rho == 0), NaN for an index
// out of range (but outputs whose length depends on the case: nothing says how long they are).
// With caches, the plain switch is host only, and <kernel>_prepare(p, pc) fills every function's
// values one after the other, in `functions`' order, for the switch taking pc (any device).
void write_case_switch(const TracedModel& m, KernelId id, const std::vector<CaseFunction>& functions,
                       Buffer& out) {
  const Signature& sig = signature(id);
  std::vector<std::string> args = arguments(sig);
  args.erase(args.begin());  // the index
  const std::size_t cases = per_frame(id) ? m.frames.size() : m.contact_sets.size();
  const bool cached =
      std::any_of(functions.begin(), functions.end(), [](const CaseFunction& f) { return f.cache > 0; });
  const bool returns = sig.result != "void";
  std::vector<int> pc_at(functions.size());  // each function's values in pc
  for (std::size_t k = 1; k < functions.size(); ++k) pc_at[k] = pc_at[k - 1] + functions[k - 1].cache;
  const auto call = [&](std::size_t k, bool with_pc) {
    const CaseFunction& f = functions[k];
    std::string pass = fmt::format("{}", fmt::join(args, ", "));
    const int at = pc_at[f.shares.value_or(k)];
    if (with_pc && (f.cache > 0 || f.shares))
      pass += at > 0 ? fmt::format(", pc + {}", at) : std::string(", pc");
    return fmt::format("{}_{}{}({})", sig.name, f.index, f.exact ? "_exact" : "", pass);
  };
  const auto write_switch = [&](bool with_pc) {
    std::vector<std::string> ps = parameters(sig, nullptr);
    if (with_pc) ps.emplace_back("const double* pc");
    fmt::format_to(std::back_inserter(out), "{}{}\n  switch ({}) {{\n", with_pc || !cached ? detail::host_device : "",
                   wrap(fmt::format("{} {}(", sig.result, sig.name), ps, ") noexcept {"), sig.leading.at(0).name);
    for (std::size_t i = 0; i < cases; ++i) {
      std::optional<std::size_t> general, exact;
      for (std::size_t k = 0; k < functions.size(); ++k)
        if (functions[k].index == static_cast<int>(i)) (functions[k].exact ? exact : general) = k;
      fmt::format_to(std::back_inserter(out), "    case {}:  // {}\n", i,
                     detail::string_literal(case_name(m, id, i)));
      if (exact)
        fmt::format_to(std::back_inserter(out), "      if (rho == 0) return {};\n", call(*exact, with_pc));
      fmt::format_to(std::back_inserter(out), "      {}{};\n{}", returns ? "return " : "",
                     call(general.value(), with_pc), returns ? "" : "      return;\n");
    }
    out.append(std::string_view("  }\n"));
    for (const auto& o : sig.outputs)
      if (o.rows != Dim::contact)
        fmt::format_to(std::back_inserter(out), "  fill_nan({}, {});\n", o.name, length(o, m));
    if (returns) out.append(std::string_view("  return false;\n"));
    out.append(std::string_view("}\n"));
  };
  fmt::format_to(std::back_inserter(out), "\n// {}: {}, one case per {}\n", m.name, sig.name,
                 per_frame(id) ? "frame" : "contact set");
  write_switch(false);
  if (!cached) return;
  fmt::format_to(std::back_inserter(out),
                 "// {0}'s parameter-only values, every case's in turn, once where cases share them\n"
                 "// ({0}_parameter_cache doubles)\n"
                 "{1}void {0}_prepare(const double* p, double* pc) noexcept {{\n",
                 sig.name, detail::host_device);
  for (std::size_t k = 0; k < functions.size(); ++k) {
    if (functions[k].cache == 0) continue;
    fmt::format_to(std::back_inserter(out), "  {}_{}{}_prepare(p, {});\n", sig.name, functions[k].index,
                   functions[k].exact ? "_exact" : "",
                   pc_at[k] > 0 ? fmt::format("pc + {}", pc_at[k]) : std::string("pc"));
  }
  out.append(std::string_view("}\n"));
  write_switch(true);
}

// The generated header's definition of EOM_HOST_DEVICE (detail::host_device), the mark of what a
// GPU can run.
constexpr std::string_view host_device_definition = R"(// EOM_HOST_DEVICE marks the functions a GPU can run as well: __host__ __device__ under
// nvcc (add_eom_model(... CUDA)), nothing for a host compiler.
#if !defined(EOM_HOST_DEVICE)
#if defined(__CUDACC__)
#define EOM_HOST_DEVICE __host__ __device__
#else
#define EOM_HOST_DEVICE
#endif
#endif

)";

// Embedded helper text (the looped form's dense routine) with its functions marked for a GPU:
// EOM_HOST_DEVICE before each `inline` that opens a line or follows [[gnu::noinline]].
std::string device_text(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 1024);
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t end = std::min(text.find('\n', at), text.size() - 1) + 1;
    std::string_view line = text.substr(at, end - at);
    constexpr std::string_view noinline = "[[gnu::noinline]] inline ";
    if (line.starts_with("inline ")) {
      out += "EOM_HOST_DEVICE ";
    } else if (line.starts_with(noinline)) {
      out += "[[gnu::noinline]] EOM_HOST_DEVICE ";
      line.remove_prefix(std::string_view("[[gnu::noinline]] ").size());
    }
    out += line;
    at = end;
  }
  return out;
}

}  // namespace

EmittedFiles emit(const TracedModel& m, std::span<const Kernel> kernels_in, std::string_view ns,
                  const EmitOptions& options) {
  // Kernels in header order, whatever order they were requested in.
  std::vector<const Kernel*> kernels;
  for (const Kernel& k : kernels_in) kernels.push_back(&k);
  std::stable_sort(kernels.begin(), kernels.end(),
                   [](const Kernel* a, const Kernel* b) { return a->id < b->id; });

  EmittedFiles files;
  const std::string qualified = fmt::format("::{}", ns);
  const bool checked = std::any_of(kernels.begin(), kernels.end(), [](const Kernel* k) {
    return signature(k->id).result == "bool";
  });
  const bool taylor = std::any_of(kernels.begin(), kernels.end(), [](const Kernel* k) {
    return k->id == KernelId::taylor_coefficients;
  });
  const bool looped = std::any_of(kernels.begin(), kernels.end(),
                                  [](const Kernel* k) { return k->looped || k->row_solve; });
  const bool batch = std::any_of(kernels.begin(), kernels.end(), [](const Kernel* k) {
    return k->id == KernelId::forward_dynamics_batch;
  });
  const bool frames = std::any_of(kernels.begin(), kernels.end(), [](const Kernel* k) { return per_case(k->id); });
  // A per-case kernel (a frame's, a contact set's) is written as one function per case,
  // <kernel>_<index> (in an anonymous namespace), and the kernel itself as a switch over the
  // index that calls them.
  std::vector<std::string> function_names(kernels.size());
  std::vector<Signature> case_signatures(kernels.size());
  for (std::size_t i = 0; i < kernels.size(); ++i) {
    const Signature& sig = signature(kernels[i]->id);
    function_names[i] = per_case(kernels[i]->id) ? fmt::format("{}_{}{}", sig.name, kernels[i]->case_index(),
                                                               kernels[i]->exact ? "_exact" : "")
                                                 : std::string(sig.name);
    case_signatures[i] = sig;
    case_signatures[i].name = function_names[i];
    case_signatures[i].leading.clear();
    if (per_contact_set(kernels[i]->id))
      for (auto& o : case_signatures[i].outputs)
        if (o.rows == Dim::contact) o.count = m.contact_sets.at(kernels[i]->contact_set).rows() * size(o.cols, m);
  }

  // The parameter caches of the kernels written by KernelWriter (the Taylor and batch kernels
  // compute their parameter-only values inline).
  std::vector<ParameterCache> caches(kernels.size());
  std::vector<LoopedSystem> systems(kernels.size());
  bool any_cache = false;
  {
    for (std::size_t i = 0; i < kernels.size(); ++i) {
      const Kernel* k = kernels[i];
      if (k->id == KernelId::taylor_coefficients || k->id == KernelId::forward_dynamics_batch) continue;
      std::vector<NodeId> roots = k->roots();
      if (k->looped) {
        systems[i] = looped_system(m, *k);
        roots = systems[i].kernel.roots();
        if (systems[i].rhs) roots.insert(roots.end(), k->outputs.begin(), k->outputs.end());
      }
      ParameterCache& c = caches[i];
      c.accessor = fmt::format("{}_parameters", function_names[i]);
      c.values = parameter_frontier(m.graph, roots);
      if (!worth_caching(m.graph, c.values, m.np())) c.values.clear();
      c.index.assign(m.graph.size(), -1);
      for (std::size_t j = 0; j < c.values.size(); ++j) c.index[c.values[j]] = static_cast<int>(j);
      any_cache = any_cache || !c.values.empty();
    }
  }

  // ---- source ----
  Buffer s;
  fmt::format_to(std::back_inserter(s),
                 "// {}: equations of motion of {}, generated by eomgen.\n// Do not edit.\n"
                 "#include \"{}.hpp\"\n\n#include <cmath>\n{}{}{}#include <limits>\n{}\nnamespace {} {{\n",
                 m.name, m.class_name, m.name, taylor ? "#include <cstddef>\n" : "",
                 checked || looped ? "#include <cstdint>\n" : "", checked || any_cache ? "#include <cstring>\n" : "",
                 checked || looped ? "#if defined(__SSE2__) && !defined(__CUDA_ARCH__)\n#include <immintrin.h>\n"
                           "#endif\n"
                         : "",
                 ns);
  s.append(detail::clang_unused_begin);
  if (checked || frames) s.append(std::string_view("namespace {\n\n"));
  if (checked) {
    fmt::format_to(std::back_inserter(s),
                   "// The relative pivot test of eom::linalg::pivot_ok: a pivot at or below {0} eps\n"
                   "// times its diagonal entry means the matrix is numerically singular.\n"
                   "EOM_HOST_DEVICE\n"
                   "inline bool pivot_ok(double pivot, double diagonal) noexcept {{\n"
                   "  return pivot > {0} * std::numeric_limits<double>::epsilon() * diagonal &&\n"
                   "         diagonal > 0 && std::isfinite(pivot);\n"
                   "}}\n",
                   literal(eom::linalg::pivot_factor));
    s.append(std::string_view(
        "// Integer operations on the bits, which leave the floating-point units to the kernel, and one\n"
        "// branch: an exponent field of all ones (infinity, NaN) plus one carries into the sign bit.\n"
        "EOM_HOST_DEVICE\n"
        "inline std::uint64_t nonfinite_carry(double x) noexcept {\n"
        "  std::uint64_t bits;\n"
        "  std::memcpy(&bits, &x, sizeof bits);\n"
        "  return (bits & 0x7ff0000000000000u) + 0x0010000000000000u;\n"
        "}\n"
        "EOM_HOST_DEVICE\n"
        "inline int nonfinite(double x) noexcept { return static_cast<int>(nonfinite_carry(x) >> 63); }\n"
        "// The same four (AVX2) or two (SSE2) elements at a time, the last group overlapping the one\n"
        "// before it, the carries' sign bits gathered by one movemask: nonzero if one is not finite.\n"
        "EOM_HOST_DEVICE\n"
        "inline int nonfinite(const double* x, int n) noexcept {\n"
        "#if defined(__AVX2__) && !defined(__CUDA_ARCH__)\n"
        "  if (n >= 4) {\n"
        "    const __m256i exponent = _mm256_set1_epi64x(0x7ff0000000000000);\n"
        "    const __m256i one = _mm256_set1_epi64x(0x0010000000000000);\n"
        "    __m256i carry = _mm256_setzero_si256();\n"
        "    for (int i = 0; i < n; i += 4) {\n"
        "      const double* at = x + (i + 4 <= n ? i : n - 4);\n"
        "      const __m256i bits = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(at));\n"
        "      carry = _mm256_or_si256(carry, _mm256_add_epi64(_mm256_and_si256(bits, exponent), one));\n"
        "    }\n"
        "    return _mm256_movemask_pd(_mm256_castsi256_pd(carry));\n"
        "  }\n"
        "#endif\n"
        "#if defined(__SSE2__) && !defined(__CUDA_ARCH__)\n"
        "  if (n >= 2) {\n"
        "    const __m128i exponent = _mm_set1_epi64x(0x7ff0000000000000);\n"
        "    const __m128i one = _mm_set1_epi64x(0x0010000000000000);\n"
        "    __m128i carry = _mm_setzero_si128();\n"
        "    for (int i = 0; i < n; i += 2) {\n"
        "      const double* at = x + (i + 2 <= n ? i : n - 2);\n"
        "      const __m128i bits = _mm_loadu_si128(reinterpret_cast<const __m128i*>(at));\n"
        "      carry = _mm_or_si128(carry, _mm_add_epi64(_mm_and_si128(bits, exponent), one));\n"
        "    }\n"
        "    return _mm_movemask_pd(_mm_castsi128_pd(carry));\n"
        "  }\n"
        "#endif\n"
        "  std::uint64_t carry = 0;\n"
        "  for (int i = 0; i < n; ++i) carry |= nonfinite_carry(x[i]);\n"
        "  return static_cast<int>(carry >> 63);\n"
        "}\n"
        "EOM_HOST_DEVICE\n"
        "inline bool is_finite(double x) noexcept { return nonfinite(x) == 0; }\n"
        "EOM_HOST_DEVICE\n"
        "inline bool all_finite(const double* x, int n) noexcept { return nonfinite(x, n) == 0; }\n"));
  }
  if (checked || frames)
    s.append(std::string_view(
        "EOM_HOST_DEVICE\n"
        "inline void fill_nan(double* x, int n) noexcept {\n"
        "  for (int i = 0; i < n; ++i) x[i] = std::numeric_limits<double>::quiet_NaN();\n"
        "}\n\n"));
  if (taylor) {
    s.append(detail::taylor_recurrences_text());
    s.append(std::string_view("\n"));
  }
  if (looped) s.append(device_text(detail::dense_solve_text()));
  if (checked || frames) s.append(std::string_view("}  // namespace\n"));
  if (batch) {
    s.append(detail::host_pass_begin);
    s.append(detail::batch_support_text(options.batch_lanes));
    s.append(detail::host_pass_end);
  }
  {  // the sincos_n helper, when some kernel may have enough angles to call it
    std::vector<NodeId> angles;
    for (NodeId n = 0; n < m.graph.size(); ++n)
      if (is_angle(m.graph, n)) angles.push_back(m.graph[n].arg[0]);
    std::sort(angles.begin(), angles.end());
    if (std::unique(angles.begin(), angles.end()) - angles.begin() >=
        static_cast<std::ptrdiff_t>(vector_trig_from))
      s.append(trig_helper_text);
  }
  std::size_t taylor_workspace = 0;
  std::vector<std::pair<KernelId, int>> workspaces;  // kernels with a `double* work` overload
  // The doubles of each kernel's parameter cache (<kernel>_prepare's pc; a per-case kernel's:
  // every case's, those it shares with an earlier case once), for kernels that read one; and each
  // case function's, for the switch.
  std::vector<std::pair<KernelId, int>> parameter_caches;
  std::vector<CaseFunction> case_functions;
  for (std::size_t i = 0; i < kernels.size(); ++i) {
    const Kernel* k = kernels[i];
    s.append(std::string_view("\n"));
    if (k->id == KernelId::taylor_coefficients) {  // host code only
      std::size_t scratch = 0;
      files.operation_counts.emplace_back(
          k->id, detail::write_taylor_kernel(m, *k, s, taylor_workspace, scratch));
      workspaces.emplace_back(k->id, static_cast<int>(scratch));
      continue;
    }
    if (k->id == KernelId::forward_dynamics_batch) {  // GCC's vector extensions: host pass only
      s.append(detail::host_pass_begin);
      files.operation_counts.emplace_back(k->id, detail::write_batch_kernel(m, *k, options, s));
      s.append(detail::host_pass_end);
      continue;
    }
    if (per_case(k->id)) {
      s.append(std::string_view("namespace {\n\n"));
      // A case whose parameter-only values are an earlier case's (a contact set's exact twin; sets
      // that differ in frames only) reads that case's cache, thread_local or in pc
      std::optional<std::size_t> shares;
      const std::size_t first = i - case_functions.size();  // case_functions[0]'s kernel
      for (std::size_t j = 0; j < case_functions.size() && !shares && !caches[i].values.empty(); ++j)
        if (case_functions[j].cache > 0 && caches[first + j].values == caches[i].values) shares = j;
      if (shares)
        caches[i].accessor = caches[first + *shares].accessor;
      else if (!caches[i].values.empty())
        write_parameter_cache(m, case_signatures[i], caches[i], s);
      fmt::format_to(std::back_inserter(s), "// {} {}: {}{}\n", per_frame(k->id) ? "frame" : "contact set",
                     k->case_index(), detail::string_literal(case_name(m, k->id, k->case_index())),
                     k->exact ? ", at rho = 0 (the exact solve)" : "");
      KernelWriter w(m, *k, case_signatures[i], &caches[i]);
      files.operation_counts.emplace_back(k->id, w.write(s));
      const int own = w.cached() && !shares ? static_cast<int>(caches[i].values.size()) : 0;
      case_functions.push_back({k->case_index(), k->exact, own, w.cached() ? shares : std::nullopt});
      s.append(std::string_view("\n}  // namespace\n"));
      if (i + 1 == kernels.size() || kernels[i + 1]->id != k->id) {
        write_case_switch(m, k->id, case_functions, s);
        int total = 0;
        for (const CaseFunction& f : case_functions) total += f.cache;
        if (total > 0) parameter_caches.emplace_back(k->id, total);
        case_functions.clear();
      }
      continue;
    }
    if (!caches[i].values.empty()) write_parameter_cache(m, signature(k->id), caches[i], s);
    KernelWriter w = k->looped ? KernelWriter(m, systems[i], &caches[i]) : KernelWriter(m, *k, &caches[i]);
    files.operation_counts.emplace_back(k->id, w.write(s));
    workspaces.emplace_back(k->id, w.workspace());
    if (w.cached()) parameter_caches.emplace_back(k->id, static_cast<int>(caches[i].values.size()));
  }
  fmt::format_to(std::back_inserter(s), "\n}}  // namespace {}\n", ns);
  s.append(detail::clang_unused_end);

  // ---- header (after the source, which sizes the Taylor workspace) ----
  Buffer h;
  fmt::format_to(std::back_inserter(h),
                 "// {}: equations of motion of {}, generated by eomgen.\n"
                 "// Do not edit: change the model and rebuild. Matrices are column-major; p holds\n"
                 "// the free parameters.\n"
                 "#pragma once\n\n#include <array>\n#include <limits>\n#include <string_view>\n\n{}namespace {} {{\n\n",
                 m.name, m.class_name, host_device_definition, ns);
  fmt::format_to(std::back_inserter(h),
                 "inline constexpr int nq = {};\ninline constexpr int np = {};\n"
                 "inline constexpr int nu = {};\ninline constexpr int nc = {};\n"
                 "// velocities v (qd, qdd): nq - 1 with a free joint (x, y, z, qw, qx, qy, qz\n"
                 "// first in q; vx, vy, vz, wx, wy, wz in v), else nq with v = dq/dt\n"
                 "inline constexpr int nv = {};\n",
                 m.nq, m.np(), m.nu, m.nc, m.nv);
  if (m.floating())
    fmt::format_to(std::back_inserter(h),
                   "// where each unit quaternion's w is in q (free and ball joints, one velocity\n"
                   "// fewer each: eom/model/free_joint.hpp)\n"
                   "inline constexpr std::array<int, nq - nv> quaternions{{{}}};\n",
                   fmt::join(m.quaternions, ", "));
  std::vector<std::string> names, values;
  for (const auto& n : m.parameter_names) names.push_back(fmt::format("\"{}\"", n));
  for (double v : m.parameter_values) values.push_back(literal(v));
  fmt::format_to(std::back_inserter(h),
                 "inline constexpr std::array<std::string_view, np> parameter_names{{{}}};\n"
                 "inline constexpr std::array<double, np> parameter_values{{{}}};\n",
                 fmt::join(names, ", "), fmt::join(values, ", "));
  auto quoted = [](const std::vector<std::string>& v) {
    std::vector<std::string> out;
    for (const auto& n : v) out.push_back(detail::string_literal(n));
    return out;
  };
  auto literals = [](const std::vector<double>& v) {
    std::vector<std::string> out;
    for (double x : v) out.push_back(literal(x));
    return out;
  };
  // A TracedModel made by hand (not by trace_model) may leave them out: q0…, u0…, ±inf.
  auto filled = [](std::vector<std::string> v, int n, const char* prefix) {
    for (int i = static_cast<int>(v.size()); i < n; ++i) v.push_back(fmt::format("{}{}", prefix, i));
    v.resize(static_cast<std::size_t>(n));
    return v;
  };
  auto bounds = [](std::vector<double> v, int n, double fallback) {
    v.resize(static_cast<std::size_t>(n), fallback);
    return v;
  };
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<std::string> q_names = filled(m.coordinate_names, m.nq, "q");
  const std::vector<std::string> v_names =
      m.velocity_names.empty() ? velocity_names(q_names, m.quaternions, m.floating()) : filled(m.velocity_names, m.nv, "v");
  fmt::format_to(
      std::back_inserter(h),
      "// the model's names: coordinates (q), velocities (v: a free joint's vx, vy, vz, wx, wy, wz),\n"
      "// inputs (u)\n{}\n{}\n{}\n"
      "// limits (a URDF file's <limit>), +-infinity where the model states none\n{}\n{}\n{}\n{}\n",
      wrap("inline constexpr std::array<std::string_view, nq> coordinate_names{", quoted(q_names), "};"),
      wrap("inline constexpr std::array<std::string_view, nv> velocity_names{", quoted(v_names), "};"),
      wrap("inline constexpr std::array<std::string_view, nu> input_names{",
           quoted(filled(m.input_names, m.nu, "u")), "};"),
      wrap("inline constexpr std::array<double, nq> position_lower{",
           literals(bounds(m.position_lower, m.nq, -inf)), "};"),
      wrap("inline constexpr std::array<double, nq> position_upper{",
           literals(bounds(m.position_upper, m.nq, inf)), "};"),
      wrap("inline constexpr std::array<double, nv> effort_limit{",
           literals(bounds(m.effort_limit, m.nv, inf)), "};"),
      wrap("inline constexpr std::array<double, nv> velocity_limit{",
           literals(bounds(m.velocity_limit, m.nv, inf)), "};"));
  std::vector<std::string> frame_names;
  for (const auto& f : m.frames) frame_names.push_back(detail::string_literal(f.name));
  fmt::format_to(std::back_inserter(h),
                 "// the frames FRAMES named: the frame kernels' index f runs over them\n"
                 "inline constexpr int nframes = {};\n{}\n",
                 m.frames.size(),
                 wrap("inline constexpr std::array<std::string_view, nframes> frame_names{",
                      frame_names, "};"));
  if (!m.contact_sets.empty()) {
    std::vector<std::string> set_names, rows, begin{"0"}, frames, six_d;
    std::string listed;
    for (const auto& set : m.contact_sets) {
      set_names.push_back(detail::string_literal(set.name));
      rows.push_back(std::to_string(set.rows()));
      listed += fmt::format("\n//   {}:", set.name);
      for (const auto& c : set.contacts) {
        listed += fmt::format(" {}{}", m.frames.at(c.frame).name, c.six_d ? ":6d" : "");
        frames.push_back(std::to_string(c.frame));
        six_d.emplace_back(c.six_d ? "true" : "false");
      }
      begin.push_back(std::to_string(frames.size()));
    }
    fmt::format_to(std::back_inserter(h),
                   "// the contact sets CONTACTS named: the contact kernels' index s runs over them; each\n"
                   "// set's rows (3 per point contact, 6 per 6d one, in its frames' order); its contacts\n"
                   "// [contact_begin[s], contact_begin[s + 1]), each a frame (its index f) held in\n"
                   "// position or, six_d, in placement; and the proximal steps the contact kernels take\n"
                   "// when rho > 0{}\n"
                   "inline constexpr int ncontact_sets = {};\n{}\n{}\n"
                   "inline constexpr int ncontacts = {};\n{}\n{}\n{}\n"
                   "inline constexpr int contact_proximal_iterations = {};\n",
                   listed, m.contact_sets.size(),
                   wrap("inline constexpr std::array<std::string_view, ncontact_sets> contact_set_names{",
                        set_names, "};"),
                   wrap("inline constexpr std::array<int, ncontact_sets> contact_rows{", rows, "};"),
                   frames.size(),
                   wrap("inline constexpr std::array<int, ncontact_sets + 1> contact_begin{", begin, "};"),
                   wrap("inline constexpr std::array<int, ncontacts> contact_frames{", frames, "};"),
                   wrap("inline constexpr std::array<bool, ncontacts> contact_six_d{", six_d, "};"),
                   contact_proximal_iterations);
  }
  if (taylor)
    fmt::format_to(std::back_inserter(h),
                   "// taylor_coefficients: its scratch (doubles per coefficient: work holds\n"
                   "// taylor_workspace * (order + 1)) and the highest order it accepts.\n"
                   "inline constexpr int taylor_workspace = {};\n"
                   "inline constexpr int taylor_max_order = {};\n",
                   taylor_workspace, taylor_max_order);
  if (batch) h.append(detail::batch_lanes_declaration(options.batch_lanes));
  // Each kernel once (a per-frame kernel has one Kernel per frame).
  std::vector<const Kernel*> declared;
  for (const Kernel* k : kernels)
    if (declared.empty() || declared.back()->id != k->id) declared.push_back(k);
  // What a declared kernel has: a `work` overload (its size), a parameter cache (its size), and
  // whether its signatures without pc run on a GPU (not those that read the thread_local cache,
  // nor the Taylor and batch kernels).
  const auto workspace_of = [&](KernelId id) {
    const auto w = std::find_if(workspaces.begin(), workspaces.end(),
                                [&](const auto& e) { return e.first == id && e.second > 0; });
    return w == workspaces.end() ? 0 : w->second;
  };
  const auto cache_of = [&](KernelId id) {
    const auto c = std::find_if(parameter_caches.begin(), parameter_caches.end(),
                                [&](const auto& e) { return e.first == id; });
    return c == parameter_caches.end() ? 0 : c->second;
  };
  const auto device = [&](KernelId id) {
    return id != KernelId::taylor_coefficients && id != KernelId::forward_dynamics_batch &&
           cache_of(id) == 0;
  };
  const auto mark = [](bool device_too, std::string_view indent = "") {
    return device_too ? fmt::format("{}{}", indent, detail::host_device) : std::string();
  };
  for (const Kernel* k : declared) {
    if (k->id == KernelId::forward_dynamics_batch) {
      h.append(detail::batch_declaration(qualified, false));
      continue;
    }
    const Signature& sig = signature(k->id);
    const std::string head = fmt::format("{} {}(", sig.result, sig.name);
    // (taylor_coefficients with quaternions: qdk's rows are nv, q's rate G(q) v)
    const std::string_view summary = m.floating() && k->id == KernelId::taylor_coefficients
                                         ? floating_taylor_summary
                                         : signature(k->id).summary;
    fmt::format_to(std::back_inserter(h), "\n// {}\n{}{}\n", summary, mark(device(k->id)),
                   wrap(head, parameters(sig, nullptr), ") noexcept;"));
    const int ws = workspace_of(k->id), pc = cache_of(k->id);
    if (ws > 0) {
      std::vector<std::string> ps = parameters(sig, nullptr);
      ps.push_back(fmt::format("double* {}", scratch_name(sig)));
      fmt::format_to(std::back_inserter(h),
                     "// The same, its scratch in `{3}` (the caller's): {0}_workspace doubles.\n"
                     "inline constexpr int {0}_workspace = {1};\n{4}{2}\n",
                     sig.name, ws, wrap(head, ps, ") noexcept;"), scratch_name(sig),
                     mark(device(k->id)));
    }
    if (pc == 0) continue;
    std::vector<std::string> ps = parameters(sig, nullptr);
    ps.emplace_back("const double* pc");
    std::vector<std::string> words;
    const std::string note = fmt::format(
        "The same with p's parameter-only values in pc, the caller's: {0}_prepare(p, pc) fills "
        "its {0}_parameter_cache doubles once per p; no thread_local cache (GPUs, hard real "
        "time). Pass pc as const double*{1}.",
        sig.name, ws > 0 ? fmt::format(" (a double* picks the overload taking {})", scratch_name(sig)) : "");
    for (std::string_view text = note; !text.empty();) {
      const std::size_t end = std::min(text.find(' '), text.size());
      words.emplace_back(text.substr(0, end));
      text.remove_prefix(std::min(end + 1, text.size()));
    }
    std::string comment, line = "//";
    for (const std::string& w : words) {
      if (line.size() + 1 + w.size() > 100) comment += line + "\n", line = "//";
      line += " " + w;
    }
    comment += line + "\n";
    fmt::format_to(std::back_inserter(h),
                   "{3}inline constexpr int {0}_parameter_cache = {1};\n"
                   "{2}void {0}_prepare(const double* p, double* pc) noexcept;\n{2}{4}\n",
                   sig.name, pc, detail::host_device, comment, wrap(head, ps, ") noexcept;"));
    if (ws > 0) {
      ps.insert(ps.end() - 1, fmt::format("double* {}", scratch_name(sig)));
      fmt::format_to(std::back_inserter(h), "{}{}\n", detail::host_device, wrap(head, ps, ") noexcept;"));
    }
  }
  fmt::format_to(std::back_inserter(h),
                 "\n// The model as one type, for the runtime's templates (like "
                 "eom::Reference<Model>).\nstruct Kernels {{\n"
                 "  static constexpr int nq = {0}::nq;\n"
                 "  static constexpr int nv = {0}::nv;\n"
                 "{1}"
                 "  static constexpr int np = {0}::np;\n"
                 "  static constexpr int nu = {0}::nu;\n"
                 "  static constexpr int nc = {0}::nc;\n"
                 "  static constexpr std::array<std::string_view, np> parameter_names =\n"
                 "      {0}::parameter_names;\n"
                 "  static constexpr std::array<double, np> parameter_values =\n"
                 "      {0}::parameter_values;\n"
                 "  static constexpr int nframes = {0}::nframes;\n"
                 "  static constexpr std::array<std::string_view, nframes> frame_names =\n"
                 "      {0}::frame_names;\n"
                 "  static constexpr std::array<std::string_view, nq> coordinate_names =\n"
                 "      {0}::coordinate_names;\n"
                 "  static constexpr std::array<std::string_view, nv> velocity_names =\n"
                 "      {0}::velocity_names;\n"
                 "  static constexpr std::array<std::string_view, nu> input_names = {0}::input_names;\n"
                 "  static constexpr std::array<double, nq> position_lower = {0}::position_lower;\n"
                 "  static constexpr std::array<double, nq> position_upper = {0}::position_upper;\n"
                 "  static constexpr std::array<double, nv> effort_limit = {0}::effort_limit;\n"
                 "  static constexpr std::array<double, nv> velocity_limit = {0}::velocity_limit;\n",
                 qualified,
                 m.floating() ? fmt::format("  static constexpr std::array<int, nq - nv> quaternions = "
                                            "{}::quaternions;\n", qualified)
                              : std::string());
  if (!m.contact_sets.empty())
    fmt::format_to(std::back_inserter(h),
                   "  static constexpr int ncontact_sets = {0}::ncontact_sets;\n"
                   "  static constexpr std::array<std::string_view, ncontact_sets> contact_set_names =\n"
                   "      {0}::contact_set_names;\n"
                   "  static constexpr std::array<int, ncontact_sets> contact_rows = {0}::contact_rows;\n"
                   "  static constexpr int ncontacts = {0}::ncontacts;\n"
                   "  static constexpr std::array<int, ncontact_sets + 1> contact_begin = {0}::contact_begin;\n"
                   "  static constexpr std::array<int, ncontacts> contact_frames = {0}::contact_frames;\n"
                   "  static constexpr std::array<bool, ncontacts> contact_six_d = {0}::contact_six_d;\n"
                   "  static constexpr int contact_proximal_iterations = {0}::contact_proximal_iterations;\n",
                   qualified);
  if (taylor)
    fmt::format_to(std::back_inserter(h),
                   "  static constexpr int taylor_workspace = {0}::taylor_workspace;\n"
                   "  static constexpr int taylor_max_order = {0}::taylor_max_order;\n",
                   qualified);
  if (batch)
    fmt::format_to(std::back_inserter(h), "  static constexpr int batch_lanes = {}::batch_lanes;\n",
                   qualified);
  // A static member forwarding to the namespace's function: parameters ps, arguments as.
  const auto forward = [&](const Signature& sig, std::string_view name, const std::vector<std::string>& ps,
                           const std::vector<std::string>& as, bool device_too) {
    fmt::format_to(std::back_inserter(h), "{}{}\n{}\n  }}\n", mark(device_too, "  "),
                   wrap(fmt::format("  static {} {}(", sig.result, name), ps, ") noexcept {"),
                   wrap(fmt::format("    {}{}::{}(", sig.result == "void" ? "" : "return ", qualified, name),
                        as, ");"));
  };
  for (const Kernel* k : declared) {
    if (k->id == KernelId::forward_dynamics_batch) {
      h.append(detail::batch_declaration(qualified, true));
      continue;
    }
    const Signature& sig = signature(k->id);
    forward(sig, sig.name, parameters(sig, nullptr), arguments(sig), device(k->id));
    const int ws = workspace_of(k->id), pc = cache_of(k->id);
    if (ws > 0) {
      std::vector<std::string> ps = parameters(sig, nullptr), as = arguments(sig);
      ps.push_back(fmt::format("double* {}", scratch_name(sig)));
      as.emplace_back(scratch_name(sig));
      fmt::format_to(std::back_inserter(h), "  static constexpr int {0}_workspace =\n      {1}::{0}_workspace;\n",
                     sig.name, qualified);
      forward(sig, sig.name, ps, as, device(k->id));
    }
    if (pc == 0) continue;
    fmt::format_to(std::back_inserter(h),
                   "  static constexpr int {0}_parameter_cache =\n      {1}::{0}_parameter_cache;\n",
                   sig.name, qualified);
    const Signature prepare{"", "", "void", {}, {}};
    forward(prepare, fmt::format("{}_prepare", sig.name), {"const double* p", "double* pc"}, {"p", "pc"}, true);
    std::vector<std::string> ps = parameters(sig, nullptr), as = arguments(sig);
    ps.emplace_back("const double* pc");
    as.emplace_back("pc");
    forward(sig, sig.name, ps, as, true);
    if (ws > 0) {
      ps.insert(ps.end() - 1, fmt::format("double* {}", scratch_name(sig)));
      as.insert(as.end() - 1, std::string(scratch_name(sig)));
      forward(sig, sig.name, ps, as, true);
    }
  }
  fmt::format_to(std::back_inserter(h), "}};\n\n}}  // namespace {}\n", ns);

  files.header = fmt::to_string(h);
  files.source = fmt::to_string(s);
  return files;
}

}  // namespace eom::gen
