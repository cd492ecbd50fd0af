// The model contract (docs/CONTRACT.md §1): a struct with static members, every function templated on the
// scalar S so that one source runs with double, the AD reference number, the generator's recording
// scalar and wide types. eom::ModelInfo<M> validates a model at compile time; each failed check is
// a static_assert whose message names the field or function at fault.
#pragma once

#include <algorithm>
#include <array>
#include <concepts>
#include <cstddef>
#include <span>
#include <string_view>
#include <type_traits>

#include "eom/model/free_joint.hpp"
#include "eom/numeric/ad.hpp"

namespace eom {

template <class S> using In = std::span<const S>;
template <class S> using Out = std::span<S>;

// The one way to write a piecewise expression: `cond` comes from comparing scalars. Plain and AD
// scalars compare to bool; a recording scalar compares to its own condition type, and its
// namespace supplies `eom_select` (found by argument-dependent lookup) to record the choice.
template <class C, class S>
S select(const C& cond, const S& if_true, const S& if_false) {
  if constexpr (std::is_same_v<C, bool>)
    return cond ? if_true : if_false;
  else
    return eom_select(cond, if_true, if_false);
}

// The body form (the paper's "modified Lagrangian form", eqs. 17-24): instead of T the model
// states, per rigid body, its mass, its inertia about the mass centre, and the mass centre's
// position and the body's orientation as functions of q:
//   static constexpr int body_count = N;
//   template <class S> static void bodies(In<S> q, In<S> p, Out<Body<S>> b);
// where Body is PlanarBody or SpatialBody: the type written into `b` selects the kinematics.
// Then vᵢ = Aᵢ q̇ with Aᵢ = ∂rᵢ/∂q and ωᵢ = Bᵢ q̇, and
//   T = ½ Σᵢ (mᵢ |Aᵢ q̇|² + ωᵢᵀ Jᵢ ωᵢ),  so  M = Σᵢ (mᵢ AᵢᵀAᵢ + BᵢᵀJᵢBᵢ)  (eq. 21).

// A body moving in the x-y plane: ω = θ̇, J = the scalar inertia about the mass centre.
template <class S> struct PlanarBody {
  S mass{}, inertia{};  // inertia about the mass centre, for rotation in the plane
  S x{}, y{};           // mass-centre position
  S angle{};            // orientation in the plane
};

// A body moving in space. ω is the body-axes angular velocity, the axial vector of RᵀṘ.
// Helpers that build rotations and rigid transforms for it are in <eom/multibody/spatial.hpp>.
template <class S> struct SpatialBody {
  S mass{};
  std::array<S, 6> inertia{};   // about the mass centre, in body axes: Ixx, Iyy, Izz, Ixy, Ixz, Iyz
                                // (tensor entries, I = [[Ixx Ixy Ixz] [Ixy Iyy Iyz] [Ixz Iyz Izz]])
  std::array<S, 3> position{};  // mass centre, world frame
  std::array<S, 9> rotation{};  // body-to-world rotation matrix, column-major
};

// A frame a controller reads (docs/CONTRACT.md §1, frames): where its origin is and how it is
// turned. A model declares its frames' names and where they are:
//   static constexpr std::array frame_names{"tool", ...};
//   template <class S> static void frames(eom::In<S> q, eom::In<S> p, eom::Out<eom::Frame<S>> f);
// (a tree-form model may instead fix each frame to one of its links, eom/multibody/tree.hpp's link_frames).
template <class S> struct Frame {
  std::array<S, 3> position{};  // the origin, world frame
  std::array<S, 9> rotation{};  // frame axes -> world, column-major
};

namespace detail {

template <class> inline constexpr bool always_false = false;

template <class A> struct is_std_array : std::false_type {};
template <class T, std::size_t N> struct is_std_array<std::array<T, N>> : std::true_type {};

template <class A, class Elem>
concept array_of = is_std_array<std::remove_cvref_t<A>>::value &&
                   std::convertible_to<typename std::remove_cvref_t<A>::value_type, Elem>;

template <class A> constexpr std::size_t array_size = std::tuple_size_v<std::remove_cvref_t<A>>;

// A name is usable in generated code and in FIXED_PARAMETERS: a C identifier.
constexpr bool is_identifier(std::string_view s) {
  if (s.empty()) return false;
  auto alpha = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; };
  if (!alpha(s[0])) return false;
  for (char c : s)
    if (!alpha(c) && !(c >= '0' && c <= '9')) return false;
  return true;
}

// No name twice, by sorting a copy: a pairwise check is quadratic and, at a 60-link URDF's 661
// parameter names, exceeds the compiler's constexpr operation limit.
template <class A> constexpr bool all_distinct(const A& names) {
  std::array<std::string_view, std::tuple_size_v<A>> sorted{};
  for (std::size_t i = 0; i < names.size(); ++i) sorted[i] = names[i];
  std::sort(sorted.begin(), sorted.end());
  return std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end();
}

template <class A> constexpr bool names_valid(const A& names) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (!is_identifier(names[i])) return false;
  return all_distinct(names);
}

using D = double;

// Frame names are names in a header and in FRAMES, not identifiers (URDF links may hold '-').
template <class A> constexpr bool distinct_names(const A& names) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (std::string_view(names[i]).empty()) return false;
  return all_distinct(names);
}

template <class M> concept has_coordinates = requires { M::coordinates; };
template <class M> concept has_parameters = requires { M::parameters; };
template <class M> concept has_parameter_values = requires { M::parameter_values; };
template <class M> concept has_inputs = requires { M::inputs; };
template <class M> concept has_constraint_names = requires { M::constraint_names; };
template <class M> concept has_floating_base = requires { M::floating_base; };
template <class M> concept has_quaternions = requires { M::quaternions; };
template <class M> concept has_frame_names = requires { M::frame_names; };
template <class M> concept declares_frames = requires { &M::template frames<double>; };
template <class M> concept declares_link_frames = requires { &M::template link_frames<double>; };

// "Declared at all" is tested by naming the specialisation; "right signature" by calling it.
template <class M> concept declares_kinetic_energy = requires { &M::template kinetic_energy<D>; };
template <class M> concept declares_potential_energy = requires { &M::template potential_energy<D>; };
template <class M> concept declares_constraints = requires { &M::template constraints<D>; };
template <class M>
concept declares_generalized_forces = requires { &M::template generalized_forces<D>; };

template <class M> concept has_body_count = requires { M::body_count; };
template <class M> concept declares_bodies = requires { &M::template bodies<D>; };
template <class M, class S, template <class> class Body>
concept bodies_callable_with = requires(In<S> x, Out<Body<S>> b) {
  { M::template bodies<S>(x, x, b) } -> std::same_as<void>;
};
template <class M, class S>
concept bodies_callable =
    bodies_callable_with<M, S, PlanarBody> || bodies_callable_with<M, S, SpatialBody>;

template <class M, class S>
concept kinetic_energy_callable = requires(In<S> x) {
  { M::template kinetic_energy<S>(x, x, x) } -> std::convertible_to<S>;
};
template <class M, class S>
concept potential_energy_callable = requires(In<S> x) {
  { M::template potential_energy<S>(x, x) } -> std::convertible_to<S>;
};
template <class M, class S>
concept constraints_callable = requires(In<S> x, Out<S> y) {
  { M::template constraints<S>(x, x, y) } -> std::same_as<void>;
};
template <class M, class S>
concept generalized_forces_callable = requires(const S& t, In<S> x, Out<S> y) {
  { M::template generalized_forces<S>(t, x, x, x, x, y) } -> std::same_as<void>;
};

template <class M> consteval std::size_t count_coordinates() {
  if constexpr (!has_coordinates<M>) {
    static_assert(always_false<M>,
                  "eom model: missing `static constexpr std::array coordinates{\"q1\", ...}`");
    return 0;
  } else {
    static_assert(array_of<decltype(M::coordinates), std::string_view>,
                  "eom model: `coordinates` must be a std::array of names (string literals)");
    static_assert(array_size<decltype(M::coordinates)> >= 1,
                  "eom model: `coordinates` must name at least one generalized coordinate");
    static_assert(names_valid(M::coordinates),
                  "eom model: `coordinates` must be distinct identifiers (letters, digits, _)");
    return array_size<decltype(M::coordinates)>;
  }
}

template <class M> consteval std::size_t count_parameters() {
  if constexpr (!has_parameters<M>) {
    static_assert(!has_parameter_values<M>,
                  "eom model: `parameter_values` given without `parameters` (their names)");
    return 0;
  } else {
    static_assert(array_of<decltype(M::parameters), std::string_view>,
                  "eom model: `parameters` must be a std::array of names (string literals)");
    static_assert(names_valid(M::parameters),
                  "eom model: `parameters` must be distinct identifiers (letters, digits, _)");
    static_assert(has_parameter_values<M>,
                  "eom model: `parameters` given without `parameter_values` (their defaults)");
    if constexpr (has_parameter_values<M>) {
      static_assert(array_of<decltype(M::parameter_values), double>,
                    "eom model: `parameter_values` must be a std::array of numbers");
      static_assert(array_size<decltype(M::parameter_values)> ==
                        array_size<decltype(M::parameters)>,
                    "eom model: `parameter_values` must have exactly one entry per name in "
                    "`parameters`, in the same order");
    }
    return array_size<decltype(M::parameters)>;
  }
}

template <class M> consteval std::size_t count_inputs() {
  if constexpr (!has_inputs<M>) {
    return 0;
  } else {
    static_assert(array_of<decltype(M::inputs), std::string_view>,
                  "eom model: `inputs` must be a std::array of names (string literals)");
    static_assert(names_valid(M::inputs),
                  "eom model: `inputs` must be distinct identifiers (letters, digits, _)");
    return array_size<decltype(M::inputs)>;
  }
}

template <class M> consteval std::size_t count_constraints() {
  if constexpr (!has_constraint_names<M>) {
    static_assert(!declares_constraints<M>,
                  "eom model: `constraints()` is defined but `constraint_names` is missing "
                  "(one name per entry of phi)");
    return 0;
  } else {
    static_assert(array_of<decltype(M::constraint_names), std::string_view>,
                  "eom model: `constraint_names` must be a std::array of names (string literals)");
    static_assert(names_valid(M::constraint_names),
                  "eom model: `constraint_names` must be distinct identifiers");
    static_assert(declares_constraints<M>,
                  "eom model: `constraint_names` is given but `template <class S> static void "
                  "constraints(eom::In<S> q, eom::In<S> p, eom::Out<S> phi)` is missing");
    static_assert(!declares_constraints<M> || constraints_callable<M, D>,
                  "eom model: `constraints` has the wrong signature; expected `template <class S> "
                  "static void constraints(eom::In<S> q, eom::In<S> p, eom::Out<S> phi)`");
    return array_size<decltype(M::constraint_names)>;
  }
}

// The model's frames: none without `frame_names`; else exactly one way to place them.
template <class M> consteval std::size_t count_frames() {
  if constexpr (!has_frame_names<M>) {
    static_assert(!declares_frames<M> && !declares_link_frames<M>,
                  "eom model: `frames()` (or `link_frames()`) is defined but `frame_names` is "
                  "missing (static constexpr std::array frame_names{\"tool\", ...})");
    return 0;
  } else {
    static_assert(array_of<decltype(M::frame_names), std::string_view>,
                  "eom model: `frame_names` must be a std::array of names (string literals)");
    static_assert(distinct_names(M::frame_names),
                  "eom model: `frame_names` must be distinct and non-empty");
    static_assert(declares_frames<M> != declares_link_frames<M>,
                  "eom model: `frame_names` needs exactly one of `template <class S> static void "
                  "frames(eom::In<S> q, eom::In<S> p, eom::Out<eom::Frame<S>> f)` or, in the tree "
                  "form, `template <class S> static void link_frames(eom::In<S> p, "
                  "eom::Out<eom::LinkFrame<S>> f)`");
    static_assert(!declares_frames<M> || requires(In<D> x, Out<Frame<D>> f) {
                    { M::template frames<D>(x, x, f) } -> std::same_as<void>;
                  }, "eom model: `frames` has the wrong signature; expected `template <class S> "
                     "static void frames(eom::In<S> q, eom::In<S> p, eom::Out<eom::Frame<S>> f)`");
    return array_size<decltype(M::frame_names)>;
  }
}

// Whether the model's first 7 coordinates are a free joint (eom/model/free_joint.hpp).
template <class M> consteval bool floating_base() {
  if constexpr (!has_floating_base<M>) {
    return false;
  } else {
    static_assert(std::is_same_v<std::remove_cv_t<decltype(M::floating_base)>, bool>,
                  "eom model: `floating_base` must be a bool (static constexpr bool floating_base "
                  "= true: q starts with x, y, z, qw, qx, qy, qz)");
    return M::floating_base;
  }
}

// Where the model's unit quaternions are (eom/model/free_joint.hpp): its `quaternions`, the q
// index of each w (a free joint's 3 first), or the free joint's alone.
template <class M> consteval auto quaternions() {
  if constexpr (has_quaternions<M>) {
    static_assert(array_of<decltype(M::quaternions), int>,
                  "eom model: `quaternions` must be a std::array of int (static constexpr "
                  "std::array quaternions{3, 10}: the q index of each unit quaternion's w)");
    constexpr std::size_t n = M::quaternions.size();
    std::array<int, n> at{};
    for (std::size_t k = 0; k < n; ++k) at[k] = M::quaternions[k];
    return at;
  } else if constexpr (floating_base<M>()) {
    return std::array<int, 1>{3};
  } else {
    return std::array<int, 0>{};
  }
}

template <class M> consteval bool check_bodies() {
  static_assert(has_body_count<M> == declares_bodies<M>,
                "eom model: the body form needs both `static constexpr int body_count` and "
                "`template <class S> static void bodies(eom::In<S> q, eom::In<S> p, "
                "eom::Out<eom::PlanarBody<S>> b)` (or eom::SpatialBody<S>)");
  if constexpr (has_body_count<M> && declares_bodies<M>) {
    static_assert(std::is_convertible_v<decltype(M::body_count), int> && M::body_count >= 1,
                  "eom model: `body_count` must be a positive integer");
    static_assert(bodies_callable<M, D>,
                  "eom model: `bodies` has the wrong signature; expected `template <class S> static "
                  "void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::PlanarBody<S>> b)` or the "
                  "same with eom::SpatialBody<S>");
    static_assert(!(bodies_callable_with<M, D, PlanarBody> && bodies_callable_with<M, D, SpatialBody>),
                  "eom model: `bodies` accepts both eom::PlanarBody and eom::SpatialBody; it must "
                  "take exactly one body type");
  }
  return true;
}

template <class M> consteval bool check_energies() {
  constexpr bool body_form = declares_bodies<M>;
  static_assert(declares_kinetic_energy<M> || body_form,
                "eom model: `template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> "
                "qd, eom::In<S> p)` is missing (or use the body form: `body_count` and `bodies`)");
  static_assert(!(declares_kinetic_energy<M> && body_form),
                "eom model: give either `kinetic_energy` or the body form (`bodies`), not both");
  static_assert(check_bodies<M>());
  static_assert(!declares_kinetic_energy<M> || kinetic_energy_callable<M, D>,
                "eom model: `kinetic_energy` has the wrong signature; expected `template <class S> "
                "static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p)`");
  static_assert(declares_potential_energy<M>,
                "eom model: `template <class S> static S potential_energy(eom::In<S> q, "
                "eom::In<S> p)` is missing");
  static_assert(!declares_potential_energy<M> || potential_energy_callable<M, D>,
                "eom model: `potential_energy` has the wrong signature; expected `template <class "
                "S> static S potential_energy(eom::In<S> q, eom::In<S> p)`");
  static_assert(!declares_generalized_forces<M> || generalized_forces_callable<M, D>,
                "eom model: `generalized_forces` has the wrong signature; expected `template "
                "<class S> static void generalized_forces(const S& t, eom::In<S> q, eom::In<S> "
                "qd, eom::In<S> u, eom::In<S> p, eom::Out<S> Q)`");
  return true;
}

}  // namespace detail

// Sizes and capabilities of a model, validated. Instantiating it is the contract check.
template <class M> struct ModelInfo {
  static constexpr int nq = static_cast<int>(detail::count_coordinates<M>());
  static constexpr int np = static_cast<int>(detail::count_parameters<M>());
  static constexpr int nu = static_cast<int>(detail::count_inputs<M>());
  static constexpr int nc = static_cast<int>(detail::count_constraints<M>());
  // A free joint (eom/model/free_joint.hpp) has 7 coordinates and 6 velocities, a ball joint 4
  // and 3: each unit quaternion in q takes one velocity fewer, nv = nq − their count.
  static constexpr bool floating_base = detail::floating_base<M>();
  static constexpr auto quaternions = detail::quaternions<M>();
  static constexpr int nv = nq - static_cast<int>(quaternions.size());
  static constexpr Layout layout{nq, nv, quaternions.data()};
  static constexpr int nframes = static_cast<int>(detail::count_frames<M>());
  static_assert(!floating_base || nq >= free_joint_nq,
                "eom model: a model with `floating_base` needs at least 7 coordinates (x, y, z, "
                "qw, qx, qy, qz first)");
  static_assert(!floating_base || quaternions[0] == 3,
                "eom model: with `floating_base`, `quaternions` starts with 3 (the free joint's "
                "qw)");
  static_assert([] {
    for (std::size_t k = 0; k < quaternions.size(); ++k)
      if (quaternions[k] < (k == 0 ? 0 : quaternions[k - 1] + 4) || quaternions[k] + 4 > nq)
        return false;
    return true;
  }(), "eom model: `quaternions` must be ascending q indices, four apart at least, each with its "
       "four coordinates inside q");
  // Runs every check (static members of a template are instantiated only when used).
  static constexpr bool valid =
      nq > 0 && np >= 0 && nu >= 0 && nc >= 0 && nframes >= 0 && detail::check_energies<M>();
  static constexpr bool has_generalized_forces = detail::declares_generalized_forces<M>;

  static constexpr std::array<std::string_view, nframes> frame_names = [] {
    std::array<std::string_view, nframes> n{};
    if constexpr (nframes > 0)
      for (int i = 0; i < nframes; ++i) n[i] = M::frame_names[i];
    return n;
  }();

  // The model's default parameter values as doubles (empty when it has no parameters).
  static constexpr std::array<double, np> default_parameters() {
    std::array<double, np> v{};
    if constexpr (np > 0)
      for (int i = 0; i < np; ++i) v[i] = static_cast<double>(M::parameter_values[i]);
    return v;
  }
};

// A type that satisfies the model contract (use ModelInfo<M> for the messages that say why not).
template <class M>
concept Model = detail::has_coordinates<M> &&
                (detail::declares_kinetic_energy<M> || detail::declares_bodies<M>) &&
                detail::declares_potential_energy<M>;

// The body type a body-form model writes (PlanarBody<S> or SpatialBody<S>).
template <class M, class S>
using BodyOf = std::conditional_t<detail::bodies_callable_with<M, double, SpatialBody>,
                                  SpatialBody<S>, PlanarBody<S>>;

namespace detail {

// The body-axes angular velocity ω = (RᵀṘ)^∨ of a rotation carried with its rate along q̇:
// [ω]× = [[0 −ω₃ ω₂] [ω₃ 0 −ω₁] [−ω₂ ω₁ 0]], so ω₁ = (RᵀṘ)₃₂, ω₂ = (RᵀṘ)₁₃, ω₃ = (RᵀṘ)₂₁, each a
// dot product of a column of R with a column of Ṙ (column-major storage).
template <class S, class V> std::array<S, 3> angular_velocity(const std::array<V, 9>& R) {
  auto column_dot = [&R](int i, int j) {  // (RᵀṘ)ᵢⱼ
    return R[3 * i].v * R[3 * j].g[0] + R[3 * i + 1].v * R[3 * j + 1].g[0] +
           R[3 * i + 2].v * R[3 * j + 2].g[0];
  };
  return {column_dot(2, 1), column_dot(0, 2), column_dot(1, 0)};
}

// sum + twice a body's kinetic energy, m|v|² + ωᵀJω, from its pose carried with its rate along q̇
// (V = Embedded<1, S, 1>: value, directional derivative).
template <class S, class V> S add_twice_kinetic_energy(const S& sum, const PlanarBody<V>& b) {
  const S &vx = b.x.g[0], &vy = b.y.g[0], &w = b.angle.g[0];
  return sum + b.mass.v * (vx * vx + vy * vy) + b.inertia.v * (w * w);
}
template <class S, class V> S add_twice_kinetic_energy(const S& sum, const SpatialBody<V>& b) {
  const auto& r = b.position;
  const S v2 = r[0].g[0] * r[0].g[0] + r[1].g[0] * r[1].g[0] + r[2].g[0] * r[2].g[0];
  const std::array<S, 3> w = angular_velocity<S>(b.rotation);
  const S &w1 = w[0], &w2 = w[1], &w3 = w[2];
  const auto& J = b.inertia;  // Ixx, Iyy, Izz, Ixy, Ixz, Iyz
  const S diagonal = J[0].v * (w1 * w1) + J[1].v * (w2 * w2) + J[2].v * (w3 * w3);
  const S off_diagonal = J[3].v * (w1 * w2) + J[4].v * (w1 * w3) + J[5].v * (w2 * w3);
  return sum + b.mass.v * v2 + diagonal + 2.0 * off_diagonal;
}

}  // namespace detail

// A body-form model's bodies with every pose carried together with its rate along q̇ = G(q) v
// (q̇ = v without a free joint): the bodies evaluated over V = Embedded<1, S, 1> (value,
// directional derivative), one first-order forward-mode pass. T (below) and the momenta
// (momentum.hpp) are read off them.
template <class M, class S>
std::array<BodyOf<M, Embedded<1, S, 1>>, M::body_count> bodies_along(In<S> q, In<S> v, In<S> p) {
  using V = Embedded<1, S, 1>;
  constexpr int nq = ModelInfo<M>::nq, np = ModelInfo<M>::np;
  std::array<S, nq> qd;
  configuration_rate(ModelInfo<M>::layout, q.data(), v.data(), qd.data());
  std::array<V, nq> qv;
  std::array<V, np> pv;
  for (int i = 0; i < nq; ++i) {
    qv[i] = V(q[i]);
    qv[i].g[0] = qd[i];
  }
  for (int i = 0; i < np; ++i) pv[i] = V(p[i]);
  std::array<BodyOf<M, V>, M::body_count> b;
  M::template bodies<V>(qv, pv, b);
  return b;
}

// T(q, v, p) of any model: its own kinetic_energy (of v), or the body form lowered as above,
// with the velocities obtained as directional derivatives of the positions along q̇ = G(q) v
// (one first-order forward-mode pass over S, so this works for every scalar type, the recording
// one included).
template <class M, class S> S kinetic_energy_of(In<S> q, In<S> v, In<S> p) {
  if constexpr (detail::declares_kinetic_energy<M>) {
    return M::template kinetic_energy<S>(q, v, p);
  } else {
    const auto b = bodies_along<M, S>(q, v, p);
    S twice_T(0);
    for (const auto& body : b) twice_T = detail::add_twice_kinetic_energy<S>(twice_T, body);
    return 0.5 * twice_T;
  }
}

}  // namespace eom
