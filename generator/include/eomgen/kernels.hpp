// From a model to the kernels of DESIGN §3, as graphs.
//
//   trace<Model>()   records T, V, φ and Q of a model into one graph (the only template step)
//   build_kernels()  derives every requested kernel on that graph (see src/kernels.cpp for the
//                    derivative strategy of each), giving per kernel its output and guard nodes
//
// All kernels share one graph, so a subexpression common to several kernels is one node; the
// emitter writes each kernel from the cone of its own outputs only.
#pragma once

#include <array>
#include <exception>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <eom/model.hpp>

#include "eomgen/graph.hpp"
#include "eomgen/tape.hpp"
#include "eomgen/taylor.hpp"

namespace eom::gen {

// The kernels of DESIGN §3, in the order the generated header declares them.
enum class KernelId {
  mass_matrix, mass_matrix_dot, coriolis, potential_gradient, generalized_forces,
  constraint_residual, constraint_jacobian, constraint_bias, forward_dynamics, kinetic_energy,
  potential_energy, forward_dynamics_derivatives, inverse_dynamics, taylor_coefficients,
};
inline constexpr int kernel_count = 14;

enum class Dim { one, nq, nc, nu, series /* order + 1 */ };

// A kernel's C++ signature: `result name(leading..., inputs..., double* outputs..., trailing...)`;
// t is `double t`, every other input `const double* x`.
struct Signature {
  struct Output {
    std::string_view name;
    Dim rows, cols;  // column-major rows × cols
  };
  struct Extra {
    std::string_view type, name;
  };
  std::string_view name;
  std::string_view result;  // "void", "double" (one output, returned) or "bool" (false: singular)
  std::vector<InputKind> inputs;
  std::vector<Output> outputs;
  std::vector<Extra> leading = {}, trailing = {};  // e.g. Taylor's `int order`, `double* work`
};
const Signature& signature(KernelId k);
std::optional<KernelId> kernel_from_name(std::string_view name);

// The model once recorded: sizes, free parameters, and its functions as nodes of `graph`.
// Inputs are the nodes graph.input(kind, i); a fixed parameter is a constant, never an input.
struct TracedModel {
  std::string name;        // the model's name (add_eom_model's <name>)
  std::string class_name;  // the C++ class, as the user wrote it
  int nq = 0, nu = 0, nc = 0;
  bool has_generalized_forces = false;
  std::vector<std::string> parameter_names;  // free parameters only, in model order
  std::vector<double> parameter_values;
  Graph graph;
  NodeId kinetic_energy = Graph::zero, potential_energy = Graph::zero;
  std::vector<NodeId> constraints, generalized_forces;

  int np() const { return static_cast<int>(parameter_names.size()); }
  std::string label() const { return "model " + name + " (" + class_name + ")"; }
};

// The kernels that apply to a model: constraint_* only when nc > 0.
std::vector<KernelId> applicable_kernels(const TracedModel& m);

struct Kernel {
  KernelId id;
  std::vector<NodeId> outputs;  // the signature's outputs, flattened in order
  std::vector<NodeId> guards;   // conditions that must all hold, else the kernel returns false
  std::optional<TaylorSystem> taylor = {};  // taylor_coefficients: the system it differentiates
};

std::vector<Kernel> build_kernels(TracedModel& m, std::span<const KernelId> requested);

// Records Model into a TracedModel. fixed[i], when set, replaces parameter i by that constant.
// Throws TraceError naming the model and function when a function branches on a traced value or
// throws while being traced.
template <class Model>
TracedModel trace(std::string name, std::string class_name,
                  std::span<const std::optional<double>> fixed = {}) {
  using Info = ModelInfo<Model>;
  static_assert(Info::valid);
  TracedModel m;
  m.name = std::move(name);
  m.class_name = std::move(class_name);
  m.nq = Info::nq;
  m.nu = Info::nu;
  m.nc = Info::nc;
  m.has_generalized_forces = Info::has_generalized_forces;
  Graph& g = m.graph;
  auto inputs = [&g](InputKind kind, int n) {
    std::vector<Expr> x;
    for (int i = 0; i < n; ++i) x.push_back(Expr::node(g.input(kind, i)));
    return x;
  };
  const std::vector<Expr> q = inputs(InputKind::q, Info::nq), qd = inputs(InputKind::qd, Info::nq),
                          u = inputs(InputKind::u, Info::nu);
  const Expr t = Expr::node(g.input(InputKind::t, 0));
  std::vector<Expr> p;
  if constexpr (Info::np > 0) {
    const auto defaults = Info::default_parameters();
    for (int i = 0; i < Info::np; ++i) {
      if (i < static_cast<int>(fixed.size()) && fixed[i]) {
        p.push_back(Expr::node(g.constant(*fixed[i])));
      } else {
        p.push_back(Expr::node(g.input(InputKind::p, m.np())));
        m.parameter_names.emplace_back(Model::parameters[i]);
        m.parameter_values.push_back(defaults[i]);
      }
    }
  }

  Tape tape(g, m.label());
  // Runs one model function under a recording named `function`, naming it in any error.
  auto record = [&tape](std::string_view function, auto&& body) {
    Tape::Recording recording(tape, function);
    try {
      body();
    } catch (const TraceError&) {
      throw;
    } catch (const std::exception& e) {
      throw TraceError(tape.model() + ": " + std::string(function) +
                       " threw while being traced: " + e.what());
    }
  };
  // kinetic_energy_of: the model's own T, or its body form lowered to T (model.hpp).
  record(eom::detail::declares_bodies<Model> ? "bodies" : "kinetic_energy", [&] {
    m.kinetic_energy = eom::kinetic_energy_of<Model, Expr>(q, qd, p).id();
  });
  record("potential_energy", [&] {
    m.potential_energy = Model::template potential_energy<Expr>(q, p).id();
  });
  if constexpr (Info::nc > 0) {
    record("constraints", [&] {
      std::vector<Expr> phi(Info::nc);
      Model::template constraints<Expr>(q, p, phi);
      for (const Expr& e : phi) m.constraints.push_back(e.id());
    });
  }
  if constexpr (Info::has_generalized_forces) {
    record("generalized_forces", [&] {
      std::vector<Expr> Q(Info::nq);
      Model::template generalized_forces<Expr>(t, q, qd, u, p, Q);
      for (const Expr& e : Q) m.generalized_forces.push_back(e.id());
    });
  }
  return m;
}

}  // namespace eom::gen
