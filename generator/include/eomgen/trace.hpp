// The trace stage: trace<Model>() records T, V, φ and Q of a model (and, for the tree form, its
// recursions; the frames asked for; the mass centre) into one graph, a TracedModel
// (eomgen/kernels.hpp). The generator's only template step: the model's code, and the runtime's
// multibody code it calls, run on the recording scalar eom::gen::Expr.
#pragma once

#include <algorithm>
#include <array>
#include <exception>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <eom/model/model.hpp>
#include <eom/multibody/frames.hpp>
#include <eom/multibody/tree.hpp>
#include <eom/multibody/tree_derivatives.hpp>

#include "eomgen/kernels.hpp"
#include "eomgen/tape.hpp"

namespace eom::gen {

// What is traced beyond T, V, φ and Q: the frames FRAMES names (indices into the model's
// frame_names), and the mass centre. The contact sets CONTACTS names need no tracing: their
// frames are among `frames` (each contact's `frame` is its index there), and trace() hands them
// on to the TracedModel.
struct TraceRequest {
  std::vector<int> frames;
  bool mass_centre = false;
  std::vector<TracedModel::ContactSet> contact_sets;
};

// Records Model into a TracedModel. fixed[i], when set, replaces parameter i by that constant.
// Throws TraceError naming the model and function when a function branches on a traced value or
// throws while being traced.
template <class Model>
TracedModel trace(std::string name, std::string class_name,
                  std::span<const std::optional<double>> fixed = {}, const TraceRequest& request = {}) {
  using Info = ModelInfo<Model>;
  static_assert(Info::valid);
  TracedModel m;
  m.name = std::move(name);
  m.class_name = std::move(class_name);
  m.nq = Info::nq;
  m.nv = Info::nv;
  m.nu = Info::nu;
  m.nc = Info::nc;
  m.has_generalized_forces = Info::has_generalized_forces;
  m.has_bodies = eom::detail::declares_bodies<Model>;
  Graph& g = m.graph;
  auto inputs = [&g](InputKind kind, int n) {
    std::vector<Expr> x;
    for (int i = 0; i < n; ++i) x.push_back(Expr::node(g.input(kind, i)));
    return x;
  };
  const std::vector<Expr> q = inputs(InputKind::q, Info::nq), qd = inputs(InputKind::qd, Info::nv),
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

  for (int i = 0; i < Info::nq; ++i) m.coordinate_names.emplace_back(Model::coordinates[i]);
  if constexpr (Info::nu > 0)
    for (int i = 0; i < Info::nu; ++i) m.input_names.emplace_back(Model::inputs[i]);
  m.quaternions.assign(Info::quaternions.begin(), Info::quaternions.end());
  m.velocity_names = velocity_names(m.coordinate_names, m.quaternions, Info::floating_base);
  auto limits = [](std::vector<double>& to, const auto& from, int n, double fallback) {
    for (int i = 0; i < n; ++i) to.push_back(fallback);
    if constexpr (!std::is_same_v<std::decay_t<decltype(from)>, std::nullptr_t>)
      for (int i = 0; i < n && i < static_cast<int>(from.size()); ++i) to[i] = static_cast<double>(from[i]);
  };
  constexpr double inf = std::numeric_limits<double>::infinity();
  if constexpr (requires { Model::position_lower; }) limits(m.position_lower, Model::position_lower, Info::nq, -inf);
  else limits(m.position_lower, nullptr, Info::nq, -inf);
  if constexpr (requires { Model::position_upper; }) limits(m.position_upper, Model::position_upper, Info::nq, inf);
  else limits(m.position_upper, nullptr, Info::nq, inf);
  if constexpr (requires { Model::effort_limit; }) limits(m.effort_limit, Model::effort_limit, Info::nv, inf);
  else limits(m.effort_limit, nullptr, Info::nv, inf);
  if constexpr (requires { Model::velocity_limit; }) limits(m.velocity_limit, Model::velocity_limit, Info::nv, inf);
  else limits(m.velocity_limit, nullptr, Info::nv, inf);

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
  if constexpr (eom::detail::tree_form<Model>()) {
    record("tree", [&] {
      const auto links = eom::tree_of<Model, Expr>(p);
      const std::vector<Expr> qdd = inputs(InputKind::qdd, Info::nv);
      std::vector<Expr> tau(Info::nv);
      eom::tree_inverse_dynamics<Expr>(links, q, qd, qdd, tau);
      for (const Expr& e : tau) m.tree_inverse_dynamics.push_back(e.id());
      // The tree's free and ball joints hold the quaternions the model lists.
      std::vector<int> held;
      for (const auto& l : links)
        if (eom::detail::quaternion_of(l) >= 0) held.push_back(eom::detail::quaternion_of(l));
      std::sort(held.begin(), held.end());
      if (held != m.quaternions) {
        auto list = [](const std::vector<int>& v) {
          std::string s;
          for (int x : v) s += (s.empty() ? "" : ", ") + std::to_string(x);
          return "q[" + s + "]";
        };
        throw std::invalid_argument("its free and ball joints hold quaternions at " + list(held) +
                                    " but the model's `quaternions` (with floating_base: 3 "
                                    "first) are at " + list(m.quaternions));
      }
      // The ABA needs one joint per coordinate and one velocity per joint but a free one: a tree
      // with mimic or ball joints solves M v̇ = τ − c.
      if (eom::articulated_body_applies(links)) {
        const std::vector<Expr> force = inputs(InputKind::rhs, Info::nv);
        std::vector<Expr> qdd_tree(Info::nv), pivots(Info::nv);
        eom::tree_forward_dynamics<Expr>(links, q, qd, force, qdd_tree, pivots);
        for (const Expr& e : qdd_tree) m.tree_forward_dynamics.push_back(e.id());
        for (const Expr& e : pivots) m.tree_pivots.push_back(e.id());
      }
      std::vector<Expr> M(Info::nv * Info::nv);
      eom::tree_mass_matrix<Expr>(links, q, M);
      for (const Expr& e : M) m.tree_mass_matrix.push_back(e.id());
      // Last, so that the nodes above keep their ids (and the kernels their text) without it.
      // The closed form's tree: no mimic joints, and no quaternion but a free root's.
      if (!eom::tree_has_mimic(links) &&
          static_cast<int>(held.size()) == (links[0].free ? 1 : 0)) {
        // V = g·Σ m z of the tree's bodies is the node g·z, z = Σ m z built as gravity_potential
        // builds it: then the closed form takes gravity along (g a parameter or a constant).
        std::array<eom::SpatialBody<Expr>, Model::link_count> b;
        eom::tree_bodies<Expr>(links, q, b);
        const NodeId z = eom::gravity_potential<Expr>(b, Expr(1.0)).id();
        const Node V = m.graph[m.potential_energy];  // copies: the graph grows below
        Expr g(0.0);
        if (V.op == Op::Mul && (V.arg[0] == z || V.arg[1] == z)) {
          const NodeId other = V.arg[0] == z ? V.arg[1] : V.arg[0];
          const Node o = m.graph[other];
          m.tree_gravity = o.op == Op::Const || (o.op == Op::Input && o.arg[0] == static_cast<NodeId>(InputKind::p));
          if (m.tree_gravity) g = Expr::node(other), m.gravity = other;
          m.one_free_root = links[0].free;
          for (std::size_t k = 1; k < links.size(); ++k) m.one_free_root &= links[k].parent >= 0;
        }
        std::vector<Expr> dq(Info::nv * Info::nv), dv(Info::nv * Info::nv), tau(Info::nv);
        eom::tree_inverse_dynamics_derivatives<Expr>(links, q, qd, qdd, dq, dv, g, tau);
        for (const Expr& e : dq) m.tree_inverse_dynamics_derivatives.push_back(e.id());
        for (const Expr& e : dv) m.tree_inverse_dynamics_derivatives.push_back(e.id());
        for (const Expr& e : tau) m.tree_closed_tau.push_back(e.id());
        if (m.tree_gravity) {  // gravity as the world's upward acceleration
          std::vector<Expr> tau_g(Info::nv);
          eom::tree_inverse_dynamics<Expr>(links, q, qd, qdd, tau_g, g);
          for (const Expr& e : tau_g) m.tree_inverse_dynamics_gravity.push_back(e.id());
          if (eom::articulated_body_applies(links)) {
            const std::vector<Expr> force = inputs(InputKind::rhs, Info::nv);
            std::vector<Expr> qdd_g(Info::nv), pivots(Info::nv);
            eom::tree_forward_dynamics<Expr>(links, q, qd, force, qdd_g, pivots, g);
            for (const Expr& e : qdd_g) m.tree_forward_dynamics_gravity.push_back(e.id());
          }
        }
      }
      if (held.empty()) {  // after the closed form, for the same reason
        std::vector<Expr> W(Info::nv * Info::nv);
        eom::tree_mass_matrix_world<Expr>(links, q, W);
        for (const Expr& e : W) m.tree_mass_matrix_world.push_back(e.id());
      }
      if (eom::articulated_body_applies(links)) {  // after the others, for the same reason
        const std::vector<Expr> force = inputs(InputKind::rhs, Info::nv);
        std::vector<Expr> qdd_tree(Info::nv), pivots(Info::nv);
        eom::tree_forward_dynamics<Expr>(links, q, qd, force, qdd_tree, pivots, eom::AbaOutward::from_parent);
        for (const Expr& e : qdd_tree) m.tree_forward_dynamics_from_parent.push_back(e.id());
        if (m.tree_gravity) {
          eom::tree_forward_dynamics<Expr>(links, q, qd, force, qdd_tree, pivots, Expr::node(m.gravity),
                                           eom::AbaOutward::from_parent);
          for (const Expr& e : qdd_tree) m.tree_forward_dynamics_gravity_from_parent.push_back(e.id());
        }
      }
    });
  }
  if constexpr (Info::nc > 0) {
    record("constraints", [&] {
      std::vector<Expr> phi(Info::nc);
      Model::template constraints<Expr>(q, p, phi);
      for (const Expr& e : phi) m.constraints.push_back(e.id());
    });
  }
  if constexpr (Info::has_generalized_forces) {
    record("generalized_forces", [&] {
      std::vector<Expr> Q(Info::nv);
      Model::template generalized_forces<Expr>(t, q, qd, u, p, Q);
      for (const Expr& e : Q) m.generalized_forces.push_back(e.id());
    });
  }
  if constexpr (Info::nframes > 0) {
    auto ids = [](const auto& x) {
      std::vector<NodeId> v;
      for (const Expr& e : x) v.push_back(e.id());
      return v;
    };
    for (int f : request.frames)
      m.frames.push_back({std::string(Info::frame_names.at(f)), {}, {}, {}});
    if constexpr (eom::detail::link_frames_form<Model>()) {
      record("link_frames", [&] {
        const auto links = eom::tree_of<Model, Expr>(p);
        std::array<eom::LinkFrame<Expr>, Info::nframes> at;
        Model::template link_frames<Expr>(p, at);
        for (std::size_t k = 0; k < request.frames.size(); ++k) {
          const eom::LinkFrame<Expr>& frame = at[request.frames[k]];
          const eom::Transform<Expr> x = eom::tree_frame_placement<Expr>(links, frame, q);
          std::vector<Expr> J(6 * Info::nv), a(6);
          eom::tree_frame_jacobian<Expr>(links, frame, q, J);
          eom::tree_frame_bias<Expr>(links, frame, q, qd, a);
          m.frames[k].placement = ids(x.translation);
          for (NodeId r : ids(x.rotation)) m.frames[k].placement.push_back(r);
          m.frames[k].jacobian = ids(J);
          m.frames[k].bias = ids(a);
        }
      });
    } else if (!request.frames.empty()) {
      record("frames", [&] {
        std::array<eom::Frame<Expr>, Info::nframes> x;
        Model::template frames<Expr>(q, p, x);
        for (std::size_t k = 0; k < request.frames.size(); ++k) {
          m.frames[k].placement = ids(x[request.frames[k]].position);
          for (NodeId r : ids(x[request.frames[k]].rotation)) m.frames[k].placement.push_back(r);
        }
      });
    }
  }
  m.contact_sets = request.contact_sets;
  if constexpr (eom::detail::declares_bodies<Model>) {
    if (request.mass_centre)
      record("bodies", [&] {
        for (const Expr& e : eom::center_of_mass<Model, Expr>(q, p)) m.center_of_mass.push_back(e.id());
        for (const Expr& e : eom::centroidal_momentum<Model, Expr>(q, qd, p))
          m.centroidal_momentum.push_back(e.id());
      });
  }
  return m;
}

}  // namespace eom::gen
