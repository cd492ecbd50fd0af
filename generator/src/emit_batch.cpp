// forward_dynamics_batch: the forward dynamics of `lanes` states at once, one state per lane of a
// GCC vector (`double __attribute__((vector_size(8 lanes)))`), in structure-of-arrays layout: entry
// i of lane l at x[i * lanes + l] for every input and output. The program is forward_dynamics's
// (unrolled form) lowered as one function without sincos_n (eomgen/program.hpp), each instruction
// one vector statement printed with the lanewise math functions batch_<f> in place of std::<f>.
//
// With unit quaternions in q (free and ball joints, eom/model/free_joint.hpp) q has nq rows and qd
// and qdd nv, as forward_dynamics's arguments.
//
// The contract per lane is forward_dynamics's: a lane whose inputs are not all finite, or whose
// M or C M⁻¹Cᵀ fails a pivot test, or whose q̈ is not finite gets NaN in its q̈, and its bit of the
// returned mask is clear. The scalar kernel returns at the first failed guard; the batch kernel
// cannot (other lanes go on), so it ands every guard into a lane mask and evaluates everything:
// a failed lane computes with NaN and Inf, harmless since floating-point exceptions do not trap.
//
// Math functions are std::'s, called lane by lane (sin and cos of one argument by one sincos), so
// every lane's q̈ equals the scalar kernel's bitwise when both are compiled alike. With
// EOM_BATCH_LIBMVEC defined (x86-64 glibc), sin and cos come from glibc's vector math library
// libmvec instead (linked through libm; its AVX2 variant under -mavx2, else SSE2): about twice as
// fast on chains, but within 4 ulp where std::sin is correctly rounded in practice, so no longer
// bitwise (within 2.4e-14 on chain10). GCC on x86-64 Linux compiles the kernel for AVX2 and for
// baseline x86-64 (target_clones), and the loader picks what the CPU runs.
#include <fmt/format.h>

#include <stdexcept>
#include <utility>

#include "emit_detail.hpp"
#include "eom/numeric/linalg.hpp"
#include "eomgen/graph.hpp"
#include "eomgen/program.hpp"
#include "ops/print.hpp"
#include "ops/table.hpp"

namespace eom::gen::detail {

namespace {

constexpr std::string_view support_text = R"(
// ---- forward_dynamics_batch: `lanes` states at once, one per lane of a GCC vector ----
// Compiled by GCC for x86-64 Linux, and not for AVX2 already, the kernel is compiled twice, for
// AVX2 and for baseline x86-64, and the loader picks the one the CPU can run (target_clones):
// 4 lanes in one register where the machine has AVX2, without requiring it.
#if !defined(EOM_BATCH_TARGETS)
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(__AVX2__) && !defined(EOM_BATCH_NO_TARGET_CLONES)
#define EOM_BATCH_TARGETS __attribute__((target_clones("avx2", "default")))
#else
#define EOM_BATCH_TARGETS
#endif
#endif
// The helpers pass vectors by value; they are internal and inlined, so GCC's note that a 32-byte
// vector argument changes the ABI without AVX concerns no interface.
#pragma GCC diagnostic ignored "-Wpsabi"
namespace {

constexpr int lanes = {LANES};
typedef double vd __attribute__((vector_size(lanes * sizeof(double))));        // a value per lane
typedef long long vm __attribute__((vector_size(lanes * sizeof(long long))));  // -1 true, 0 false

inline vd load(const double* x) noexcept {
  vd v;
  __builtin_memcpy(&v, x, sizeof v);
  return v;
}
inline void store(double* x, vd v) noexcept { __builtin_memcpy(x, &v, sizeof v); }
// (not vd{} + x, which turns -0.0 into +0.0)
inline vd broadcast(double x) noexcept {
  vd v = {};
  for (int l = 0; l < lanes; ++l) v[l] = x;
  return v;
}
// x - x is 0 for finite x, NaN for an infinite or NaN one
inline vm is_finite(vd x) noexcept { return x - x == 0.0; }
// pivot_ok of the scalar kernels, per lane
inline vm pivot_ok(vd pivot, vd diagonal) noexcept {
  return (pivot > {PIVOT_FACTOR} * std::numeric_limits<double>::epsilon() * diagonal) &
         (diagonal > 0.0) & is_finite(pivot);
}
// The lanes whose n entries of x are all finite.
inline vm finite_lanes(const double* x, int n) noexcept {
  vm ok = vm{} == 0;
  for (int i = 0; i < n; ++i) ok &= is_finite(load(x + lanes * i));
  return ok;
}
// The result of the kernel: bit l set when lane l succeeded; a failed lane's n outputs are NaN.
inline unsigned finish(vm ok, double* x, int n) noexcept {
  unsigned mask = 0;
  for (int l = 0; l < lanes; ++l) {
    if (ok[l] != 0) {
      mask |= 1u << l;
      continue;
    }
    for (int i = 0; i < n; ++i) x[lanes * i + l] = std::numeric_limits<double>::quiet_NaN();
  }
  return mask;
}

// (Functions, not templates: GCC places a template instantiated at the end of the file nowhere,
// and the pragma above no longer covers it.)
inline vd lanewise(vd x, double (*f)(double)) noexcept {
  vd r = {};
  for (int l = 0; l < lanes; ++l) r[l] = f(x[l]);
  return r;
}
inline vd lanewise(vd x, vd y, double (*f)(double, double)) noexcept {
  vd r = {};
  for (int l = 0; l < lanes; ++l) r[l] = f(x[l], y[l]);
  return r;
}
{LANEWISE}

#if (defined(EOM_BATCH_LIBMVEC) || defined(EOM_LIBMVEC)) && defined(__x86_64__) && defined(__GLIBC__) && \
    (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 22))
// libmvec's vector sin and cos (x86-64 vector function ABI names), taken `width` lanes at a time.
#if defined(__AVX2__)
constexpr int width = lanes % 4 == 0 ? 4 : 2;
#else
constexpr int width = 2;
#endif
typedef double vw __attribute__((vector_size(width * sizeof(double))));
extern "C" {
vw _ZGVbN2v_sin(vw) noexcept;  // SSE2, 2 lanes
vw _ZGVbN2v_cos(vw) noexcept;
#if defined(__AVX2__)
vw _ZGVdN4v_sin(vw) noexcept;  // AVX2, 4 lanes
vw _ZGVdN4v_cos(vw) noexcept;
#endif
}
inline vd in_pieces(vd x, vw (*f)(vw)) noexcept {
  vd r = {};
  for (int l = 0; l < lanes; l += width) {
    vw a;
    __builtin_memcpy(&a, reinterpret_cast<const double*>(&x) + l, sizeof a);
    const vw b = f(a);
    __builtin_memcpy(reinterpret_cast<double*>(&r) + l, &b, sizeof b);
  }
  return r;
}
#if defined(__AVX2__)
inline vd batch_sin(vd x) noexcept {
  return in_pieces(x, width == 4 ? _ZGVdN4v_sin : _ZGVbN2v_sin);
}
inline vd batch_cos(vd x) noexcept {
  return in_pieces(x, width == 4 ? _ZGVdN4v_cos : _ZGVbN2v_cos);
}
#else
inline vd batch_sin(vd x) noexcept { return in_pieces(x, _ZGVbN2v_sin); }
inline vd batch_cos(vd x) noexcept { return in_pieces(x, _ZGVbN2v_cos); }
#endif
inline void batch_sincos(vd x, vd& s, vd& c) noexcept {
  s = batch_sin(x);
  c = batch_cos(x);
}
using sincos_function = void (*)(const double*, double*, double*, int);
inline void batch_sincos_n(sincos_function, vd x, vd& s, vd& c) noexcept { batch_sincos(x, s, c); }
#else
inline vd batch_sin(vd x) noexcept { return lanewise(x, [](double a) { return std::sin(a); }); }
inline vd batch_cos(vd x) noexcept { return lanewise(x, [](double a) { return std::cos(a); }); }
// (GCC computes the two calls of one lane by one sincos, as in the scalar kernels)
inline void batch_sincos(vd x, vd& s, vd& c) noexcept {
  for (int l = 0; l < lanes; ++l) {
    s[l] = std::sin(x[l]);
    c[l] = std::cos(x[l]);
  }
}
// The inputs' sines and cosines by the scalar kernel's sincos_n (f: it is written further on),
// so that each lane has the scalar kernel's bits (under -ffast-math and nvcc its trig_at's
// std::sin and std::cos, sincos_n doing nothing there).
using sincos_function = void (*)(const double*, double*, double*, int);
inline void batch_sincos_n(sincos_function f, vd x, vd& s, vd& c) noexcept {
#if defined(__FAST_MATH__) || defined(__CUDACC__)
  (void)f;
  batch_sincos(x, s, c);
#else
  double a[lanes], sa[lanes], ca[lanes];
  __builtin_memcpy(a, &x, sizeof a);
  f(a, sa, ca, lanes);
  __builtin_memcpy(&s, sa, sizeof sa);
  __builtin_memcpy(&c, ca, sizeof ca);
#endif
}
#endif

}  // namespace
)";

constexpr std::string_view batch_comment =
    "// forward_dynamics for batch_lanes states at once, in vector lanes: entry i of lane l at\n"
    "// x[i * batch_lanes + l] for each input (t: batch_lanes values) and for qdd. Bit l of the\n"
    "// result is set when lane l succeeded; a lane that fails as forward_dynamics fails gets NaN\n"
    "// in its qdd (docs/CONTRACT.md §3)\n";

// The operators that take a vector and a scalar operand; anything else (a call, ?:) needs a
// constant as a vector.
bool takes_scalar(Op op) {
  return op == Op::Add || op == Op::Sub || op == Op::Mul || op == Op::Div || op == Op::Neg ||
         op == Op::Less || op == Op::LessEqual || op == Op::Equal || op == Op::NotEqual;
}

}  // namespace

// batch_<f> lane by lane for every std:: function of the operation table but sin and cos (which
// may come from libmvec, above).
std::string lanewise_functions() {
  std::string text;
  for (std::size_t i = 0; i < ops::count; ++i) {
    const ops::Info& op = ops::table[i];
    const std::string_view f = op.spelling.symbol;
    if (op.kind != ops::Kind::real || op.spelling.form != ops::Form::call || !f.starts_with("std::") ||
        op.name == "sin" || op.name == "cos")
      continue;
    const std::string_view name = f.substr(5);
    if (op.arity == 1)
      text += fmt::format(
          "inline vd batch_{0}(vd x) noexcept {{ return lanewise(x, [](double a) {{ return "
          "std::{0}(a); }}); }}\n",
          name);
    else
      text += fmt::format(
          "inline vd batch_{0}(vd x, vd y) noexcept {{\n"
          "  return lanewise(x, y, [](double a, double b) {{ return std::{0}(a, b); }});\n}}\n",
          name);
  }
  return text;
}

std::string batch_support_text(int lanes) {
  std::string text(support_text);
  for (auto [key, value] : {std::pair<std::string_view, std::string>{"{LANES}", std::to_string(lanes)},
                            {"{LANEWISE}\n", lanewise_functions()},
                            {"{PIVOT_FACTOR}", literal(eom::linalg::pivot_factor)}})
    text.replace(text.find(key), key.size(), value);
  return text;
}

std::string batch_lanes_declaration(int lanes) {
  return fmt::format("// forward_dynamics_batch: the states it evaluates per call\n"
                     "inline constexpr int batch_lanes = {};\n",
                     lanes);
}

std::string batch_declaration(std::string_view qualified, bool in_struct) {
  const std::vector<std::string> ps{"const double* t", "const double* q", "const double* qd",
                                    "const double* u", "const double* p", "double* qdd"};
  if (!in_struct)
    return fmt::format("\n{}{}\n", batch_comment,
                       wrap("unsigned forward_dynamics_batch(", ps, ") noexcept;"));
  return fmt::format("{}\n{}\n  }}\n",
                     wrap("  static unsigned forward_dynamics_batch(", ps, ") noexcept {"),
                     wrap(fmt::format("    return {}::forward_dynamics_batch(", qualified),
                          {"t", "q", "qd", "u", "p", "qdd"}, ");"));
}

std::size_t write_batch_kernel(const TracedModel& m, const Kernel& k, const EmitOptions& options,
                               Buffer& out) {
  const int lanes = options.batch_lanes;
  if (lanes != 2 && lanes != 4 && lanes != 8)
    throw std::invalid_argument(fmt::format(
        "{}: forward_dynamics_batch: {} lanes asked for; the lane count must be 2, 4 or 8",
        m.label(), lanes));
  const Graph& g = m.graph;
  // One function of vector statements: no parts, and sin and cos lane by lane (batch_sincos).
  const Program program = lower(g, k, signature(k.id), {}, {.split = false, .vector_trig = false});

  // Every input the kernel reads is loaded once, as q3, qd0, t0, ...
  const auto input_name = [](const Place& a) { return fmt::format("{}{}", name(a.input), a.index); };
  std::vector<std::string> loads;
  for (const Place& a : program.inputs)
    loads.push_back(fmt::format("  const vd {} = load({} + {} * lanes);\n", input_name(a),
                                name(a.input), a.index));
  // An operand of `user`: constants broadcast where an operator cannot take a scalar.
  const auto operand = [&](const Place& a, const Instruction& user) -> std::string {
    switch (a.kind) {
      case Place::Kind::constant: {
        bool all_const = true;
        for (int i = 0; i < arity(user.op); ++i)
          all_const = all_const && user.from[i].kind == Place::Kind::constant;
        if (takes_scalar(user.op) && !all_const) return literal(a.value);
        return fmt::format("broadcast({})", literal(a.value));
      }
      case Place::Kind::input: return input_name(a);
      case Place::Kind::local: return fmt::format("v{}", a.index);
      default: throw std::logic_error("eomgen: batch emitter given a cached, trig or workspace place");
    }
  };

  // The lanes whose inputs are finite (u and p of size 0 may be null: never read).
  // qd and qdd have nv rows (the header's nq where nv = nq: no quaternion).
  const std::string nv = m.floating() ? "nv" : "nq";
  std::vector<std::string> checks{"finite_lanes(t, 1)", "finite_lanes(q, nq)",
                                  fmt::format("finite_lanes(qd, {})", nv)};
  if (m.nu > 0) checks.emplace_back("finite_lanes(u, nu)");
  if (m.np() > 0) checks.emplace_back("finite_lanes(p, np)");

  // The inputs' sines and cosines as the scalar kernel takes them: by its sincos_n when it calls
  // one (vector_trig_from angles or more), else std::sin and std::cos as every other argument's.
  const bool scalar_sincos_n = !lower(g, k, signature(k.id), {}, {.split = false}).angles.empty();
  const auto by_sincos_n = [&](const Instruction& in) {
    return scalar_sincos_n && (in.op == Op::Sin || in.op == Op::Cos) &&
           in.from[0].kind == Place::Kind::input;
  };
  Buffer body;
  for (std::size_t i = 0; i < program.code.size(); ++i) {
    const Instruction& in = program.code[i];
    if (by_sincos_n(in)) {  // its partner next to it, when the kernel reads both
      const bool pair = i + 1 < program.code.size() &&
                        program.code[i + 1].op == ops::info(in.op).partner &&
                        program.code[i + 1].from[0] == in.from[0];
      const Instruction* sin = in.op == Op::Sin ? &in : pair ? &program.code[i + 1] : nullptr;
      const Instruction* cos = in.op == Op::Cos ? &in : pair ? &program.code[i + 1] : nullptr;
      const std::string s = sin ? fmt::format("v{}", sin->to.index) : fmt::format("no_sin{}", i);
      const std::string c = cos ? fmt::format("v{}", cos->to.index) : fmt::format("no_cos{}", i);
      fmt::format_to(std::back_inserter(body), "  vd {}, {};\n  batch_sincos_n(sincos_n, {}, {}, {});\n",
                     s, c, operand(in.from[0], in), s, c);
      if (pair) ++i;
      continue;
    }
    // sin and cos of one argument (side by side in the program) in one call: lane by lane, one
    // sincos instead of two calls.
    if (i + 1 < program.code.size() && (in.op == Op::Sin || in.op == Op::Cos)) {
      const Instruction& next = program.code[i + 1];
      if (next.op == ops::info(in.op).partner && next.from[0] == in.from[0]) {
        const Instruction& sin = in.op == Op::Sin ? in : next;
        const Instruction& cos = in.op == Op::Sin ? next : in;
        fmt::format_to(std::back_inserter(body), "  vd v{}, v{};\n  batch_sincos({}, v{}, v{});\n",
                       in.to.index, next.to.index, operand(in.from[0], in), sin.to.index,
                       cos.to.index);
        ++i;
        continue;
      }
    }
    const ops::Text args[] = {{operand(in.from[0], in)},
                              {arity(in.op) > 1 ? operand(in.from[1], in) : std::string()},
                              {arity(in.op) > 2 ? operand(in.from[2], in) : std::string()}};
    const std::string e =
        ops::print(in.op, std::span<const ops::Text>(args, arity(in.op)), std::string_view("batch_")).s;
    if (in.guard)
      fmt::format_to(std::back_inserter(body), "  ok &= {};\n", e);
    else
      fmt::format_to(std::back_inserter(body), "  const {} v{} = {};\n",
                     in.to.boolean ? "vm" : "vd", in.to.index, e);
  }

  fmt::format_to(std::back_inserter(out),
                 "// {}: forward_dynamics_batch ({} operations, {} lanes)\n", m.name,
                 program.code.size(), lanes);
  const std::vector<std::string> ps{"const double* t", "const double* q", "const double* qd",
                                    m.nu > 0 ? "const double* u" : "const double* /*u*/",
                                    m.np() > 0 ? "const double* p" : "const double* /*p*/",
                                    "double* qdd"};
  out.append(wrap("EOM_BATCH_TARGETS unsigned forward_dynamics_batch(", ps, ") noexcept {\n"));
  out.append(wrap("  vm ok = ", checks, ";\n", " &"));
  for (const std::string& l : loads) out.append(l);
  out.append(std::string_view(body.data(), body.size()));
  for (int i = 0; i < m.nv; ++i) {
    const Place& v = program.outputs.at(i);
    const std::string value = v.kind == Place::Kind::constant ? fmt::format("broadcast({})", literal(v.value))
                            : v.kind == Place::Kind::input    ? input_name(v)
                                                               : fmt::format("v{}", v.index);
    fmt::format_to(std::back_inserter(out), "  store(qdd + {} * lanes, {});\n", i, value);
  }
  fmt::format_to(std::back_inserter(out), "  return finish(ok, qdd, {});\n}}\n", nv);
  return program.code.size();
}

}  // namespace eom::gen::detail
