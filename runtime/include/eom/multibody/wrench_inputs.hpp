// External wrenches as inputs (add_eom_model(... WRENCH_INPUTS), docs/CONTRACT.md §1): the model
// eom::WrenchInputs<Model, Spec> is Model with, for each entry of Spec::wrench_inputs, 3 (a force)
// or 6 (a wrench) more inputs appended to u, and their generalized forces added to Model's:
//
//   Q += Jᵀ w,   w = (f, τ): the force on the frame's origin and the torque about it, world axes
//
// with J the frame's Jacobian (eom/multibody/frames.hpp: rows 0-2 its origin's velocity, 3-5 its
// angular velocity, world axes), so that Qᵀv = f·ẋ + τ·ω is the wrench's power. A force alone has
// τ = 0. The body-axes kinds take f (and τ) in the frame's own axes, as a thruster or a foot sensor
// gives them: w = (R f, R τ) with R the frame's rotation. What an input means is its name's:
// `<frame>_fx, _fy, _fz` (force), `_tx, _ty, _tz` (torque), in world or frame axes by the kind.
//
// Every kernel of the wrapped model then takes the wrenches through u, its derivatives too
// (∂v̇/∂u = M⁻¹Jᵀ on those columns), and so do the integrators, ensembles and Python modules; the
// generator traces this very code, and eom::Reference<eom::WrenchInputs<Model, Spec>> is its
// oracle. Frames on the links of a tree-form model (URDF, MJCF, `link_frames`): J and R come from
// the tree's recursions. Spec (add_eom_model writes it):
//
//   struct Spec {
//     static constexpr std::array<eom::WrenchInput, K> wrench_inputs{{{"tool", eom::WrenchKind::force}}};
//     static constexpr std::array<std::string_view, 3> input_names{"tool_fx", "tool_fy", "tool_fz"};
//   };
#pragma once

#include <array>
#include <cstddef>
#include <string_view>

#include "eom/model/model.hpp"
#include "eom/multibody/frames.hpp"
#include "eom/multibody/tree.hpp"

namespace eom {

enum class WrenchKind { force, wrench, body_force, body_wrench };

struct WrenchInput {
  std::string_view frame;  // one of the model's frame_names
  WrenchKind kind = WrenchKind::wrench;
};

// Inputs a wrench of this kind takes: 3 for a force, 6 for a wrench.
constexpr int wrench_input_count(WrenchKind k) {
  return k == WrenchKind::force || k == WrenchKind::body_force ? 3 : 6;
}
constexpr bool in_frame_axes(WrenchKind k) {
  return k == WrenchKind::body_force || k == WrenchKind::body_wrench;
}

namespace detail {

template <class M> constexpr auto own_input_names() {
  constexpr std::size_t n = ModelInfo<M>::nu;
  std::array<std::string_view, n> a{};
  if constexpr (n > 0)
    for (std::size_t i = 0; i < n; ++i) a[i] = M::inputs[i];
  return a;
}

template <class Spec> constexpr int wrench_input_total() {
  int n = 0;
  for (const WrenchInput& w : Spec::wrench_inputs) n += wrench_input_count(w.kind);
  return n;
}

// The index of frame `name` among M's frame_names; −1 when it is none.
template <class M> constexpr int frame_index(std::string_view name) {
  for (std::size_t i = 0; i < M::frame_names.size(); ++i)
    if (std::string_view(M::frame_names[i]) == name) return static_cast<int>(i);
  return -1;
}

}  // namespace detail

template <class Model, class Spec> struct WrenchInputs : Model {
  static_assert(detail::link_frames_form<Model>(),
                "eom::WrenchInputs (WRENCH_INPUTS): the frames must be on the links of a tree-form "
                "model (URDF, MJCF, or a model with `tree` and `link_frames`)");
  static_assert(Spec::wrench_inputs.size() > 0, "eom::WrenchInputs: no wrench inputs");
  static_assert(static_cast<int>(Spec::input_names.size()) == detail::wrench_input_total<Spec>(),
                "eom::WrenchInputs: Spec::input_names must name 3 inputs per force, 6 per wrench");

  static constexpr int model_inputs = ModelInfo<Model>::nu;
  // Each wrench's frame, as an index into frame_names.
  static constexpr auto frame_indices = [] {
    std::array<int, Spec::wrench_inputs.size()> at{};
    for (std::size_t k = 0; k < at.size(); ++k) at[k] = detail::frame_index<Model>(Spec::wrench_inputs[k].frame);
    return at;
  }();
  static_assert([] {
    for (int f : frame_indices)
      if (f < 0) return false;
    return true;
  }(), "eom::WrenchInputs: a frame of Spec::wrench_inputs is not one of the model's frame_names");
  static constexpr auto inputs = [] {
    constexpr auto own = detail::own_input_names<Model>();
    std::array<std::string_view, own.size() + Spec::input_names.size()> all{};
    for (std::size_t i = 0; i < own.size(); ++i) all[i] = own[i];
    for (std::size_t i = 0; i < Spec::input_names.size(); ++i) all[own.size() + i] = Spec::input_names[i];
    return all;
  }();

  template <class S>
  static void generalized_forces(const S& t, In<S> q, In<S> v, In<S> u, In<S> p, Out<S> Q) {
    if constexpr (ModelInfo<Model>::has_generalized_forces) {
      Model::template generalized_forces<S>(t, q, v, u.first(model_inputs), p, Q);
    } else {
      for (S& x : Q) x = S(0.0);
    }
    constexpr int nv = ModelInfo<Model>::nv;
    const auto links = tree_of<Model, S>(p);
    std::array<LinkFrame<S>, ModelInfo<Model>::nframes> frames;
    Model::template link_frames<S>(p, frames);
    int at = model_inputs;
    for (std::size_t k = 0; k < Spec::wrench_inputs.size(); ++k) {
      const WrenchInput& input = Spec::wrench_inputs[k];
      const LinkFrame<S>& frame = frames[frame_indices[k]];
      const int n = wrench_input_count(input.kind);
      std::array<S, 6> w{S(0.0), S(0.0), S(0.0), S(0.0), S(0.0), S(0.0)};
      for (int i = 0; i < n; ++i) w[i] = u[at + i];
      at += n;
      if (in_frame_axes(input.kind)) {
        const Rot3<S> R = tree_frame_placement<S>(links, frame, q).rotation;
        const Vec3<S> f{w[0], w[1], w[2]}, tau{w[3], w[4], w[5]};
        for (int r = 0; r < 3; ++r) {
          w[r] = R[r] * f[0] + R[r + 3] * f[1] + R[r + 6] * f[2];
          if (n == 6) w[r + 3] = R[r] * tau[0] + R[r + 3] * tau[1] + R[r + 6] * tau[2];
        }
      }
      std::array<S, 6 * nv> J;
      tree_frame_jacobian<S>(links, frame, q, J);
      for (int j = 0; j < nv; ++j)
        for (int r = 0; r < n; ++r) Q[j] += J[r + 6 * j] * w[r];
    }
  }
};

}  // namespace eom
