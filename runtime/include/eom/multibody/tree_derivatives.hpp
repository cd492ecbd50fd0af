// The inverse dynamics' derivatives ∂τ/∂q and ∂τ/∂v of a tree on a fixed or free base in closed form
// (O(N²) dot products), and on request τ and M as by-products: the generator traces them for
// inverse_dynamics_derivatives and forward_dynamics_derivatives wherever they take fewer operations
// than differentiating tree_inverse_dynamics (eom/multibody/tree.hpp) through the tape.
#pragma once

#include <stdexcept>
#include <string>

#include "eom/multibody/tree.hpp"

namespace eom {

// ∂τ/∂q and ∂τ/∂v of tree_inverse_dynamics (nv × nv each, column-major) in closed form, for a
// fixed base or a free root, without mimic or ball joints (else std::invalid_argument;
// differentiate tree_inverse_dynamics instead). In world axes, with S_j joint j's motion per unit rate, v_λ and
// a_λ its parent's velocity and acceleration, F_i the force on link i's subtree, I_i^c and B_i^c
// the subtree's sums of the inertias I_k and of the operators
// B_k x = I_k (x × v_k) + x ×* (I_k v_k) + v_k ×* (I_k x) (linear in x): moving q_j turns the
// subtree of joint j rigidly about S_j, and adds u_j = v_λ × S_j to its velocities and
// w_j = a_λ × S_j − u_j × v_λ + u_j × v_k to link k's acceleration; moving v_j adds S_j and
// S_j × v_k + 2 u_j. So, with i in the subtree of j (i = j included),
//   ∂τ_i/∂q_j = S_iᵀ (I_i^c w_j + B_i^c u_j),            ∂τ_i/∂v_j = S_iᵀ (B_i^c S_j + 2 I_i^c u_j),
// and with i a strict ancestor of j
//   ∂τ_i/∂q_j = S_iᵀ (S_j ×* F_j + I_j^c w_j + B_j^c u_j),  ∂τ_i/∂v_j = S_iᵀ (B_j^c S_j + 2 I_j^c u_j),
// zero otherwise: O(N²) pairs at a few dot products each, the structure of Carpentier and
// Mansard's RNEA derivatives (RSS 2018), derived here for this algorithm's inputs. B_k is kept as
// the rate of I_k, İ_k = v_k ×* I_k − I_k v_k× (symmetric, nine numbers like an inertia without
// mass), and the momentum μ_k = I_k v_k: B_k x = İ_k x + x ×* μ_k. İ_k's ḣ_k = m v + ω × h is
// μ_k's linear part, so B_k x reads x's angular part alone and B_kᵀ s has no linear part.
//
// A free root (docs/CONTRACT.md §1: v = [ẋ in world axes, ω in root axes], ∂/∂q along
// q ⊕ δ = (x + δ_lin, q ⊗ exp(δ_ang/2))) has six columns: (0, e_m), world-fixed, and the lines
// through its origin x along R e_m, which turn with the tree. Moving any of its coordinates moves
// the whole tree rigidly, so it is a joint whose parent translates at v_λ = (0, ẋ) and accelerates
// at a_λ = (0, g + ẍ) (its own acceleration then (0, ẍ) + (0, ẋ) × ω + Σ S_m ω̇_m: the spatial
// acceleration of the origin), with two differences from a chain of joints: its angular columns
// turn with each other, so their rows take the subtree form for every root column while the
// linear rows keep the ancestor form (S_i·(S_j ×* F) + (S_j × S_i)·F = 0 makes the two agree
// where S_i turns); and moving ω_j also turns the other angular columns, adding
// (Σ S_m ω_m) × S_j to every link's acceleration (2 u_j above becomes 2 u_j + (Σ S_m ω_m) × S_j).
// Checked against differences in dd_real along the tangent directions (tests/inverse_derivatives).
//
// Spatial vectors are taken about a point of each link's branch: the origin of the link that ends
// its unbranched path outward (an arm's last link; a link with several children is its own), not
// the world's. A subtree's inertia about a far point is large where its effect on the joint is
// small, and the rounding of those large terms is what M⁻¹ magnifies in a light link's row
// (M⁻¹ ∂τ against dd_real, tests/inverse_derivatives: the Panda 3.7e-15, about the base 2.5e-14;
// two Pandas on one base 3.3e-15, about the base 3.5e-14, and about one arm's end the other arm's
// rows lose: hence a point per branch). Sums and pairs that cross branches move their vectors
// between the two points.
//
// A joint's armature (TreeLink) adds armature · v̇ to its τ and armature to M's diagonal: nothing
// to either derivative.
//
// With `gravity` g the derivatives of M v̇ + c + ∂V/∂q for V = g Σ m z (eom::gravity_potential
// of the tree's bodies): the root then accelerates upwards at g.
//
// Where asked for (non-empty), also τ itself, S_iᵀ F_i, and ∂τ/∂v̇ = M (nv × nv), M_ij = S_iᵀ I_j^c S_j
// for i above j: by-products that share the vectors above (the generator takes the bias τ(q, v, 0)
// of the forward dynamics and its derivatives from here). About a far point M rounds more than
// tree_mass_matrix does in link axes (the Panda: 1.0e-15 against 5.6e-16 of max |M|), and M⁻¹
// magnifies that: the generator factors tree_mass_matrix's.
template <class S, std::size_t N>
void tree_inverse_dynamics_derivatives(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd,
                                       In<S> qdd, Out<S> dtau_dq, Out<S> dtau_dv,
                                       const S& gravity = S(0), Out<S> tau = {},
                                       Out<S> mass = {}) {
  using detail::cross, detail::plus, detail::minus;
  detail::check_tree(links, q.size(), qd.size());
  const bool floating = N > 0 && links[0].free;
  bool other_quaternions = false;
  for (std::size_t k = 1; k < N; ++k) other_quaternions |= links[k].free || links[k].ball;
  if (other_quaternions || tree_has_mimic(links) || q.size() != qd.size() + (floating ? 1 : 0))
    throw std::invalid_argument("eom::tree_inverse_dynamics_derivatives: a ball joint, a free joint "
                                "other than the root, or mimic joints; differentiate "
                                "tree_inverse_dynamics instead");
  const std::size_t nv = qd.size();
  if (dtau_dq.size() != nv * nv || dtau_dv.size() != nv * nv ||
      !(tau.empty() || tau.size() == nv) || !(mass.empty() || mass.size() == nv * nv))
    throw std::invalid_argument("eom::tree_inverse_dynamics_derivatives: outputs of sizes " +
                                std::to_string(dtau_dq.size()) + ", " + std::to_string(dtau_dv.size()) +
                                ", " + std::to_string(tau.size()) + ", " + std::to_string(mass.size()) +
                                " for " + std::to_string(nv) + " velocities (nv², nv², nv or 0, nv² or 0)");
  const Vec3<S> zero{S(0), S(0), S(0)};
  using Six = detail::Pair<S>;
  using detail::sum, detail::scale, detail::dot;
  auto dot3 = [](const Vec3<S>& x, const Vec3<S>& y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  auto cross_motion = [](const Six& m, const Six& x) {  // m × x
    return Six{cross(m.a, x.a), plus(cross(m.a, x.b), cross(m.b, x.a))};
  };
  auto cross_force = [](const Six& m, const Six& f) {  // m ×* f
    return Six{plus(cross(m.a, f.a), cross(m.b, f.b)), cross(m.a, f.b)};
  };
  // A spatial inertia about a point: mass m, first moment h = m c, rotational inertia J about the
  // point; I (ω, v) = (J ω + h × v, m v − h × ω).
  struct Inertia {
    S m;
    Vec3<S> h;
    std::array<S, 6> J;
  };
  auto times = [](const Inertia& I, const Six& x) {
    const Vec3<S> mv{I.m * x.b[0], I.m * x.b[1], I.m * x.b[2]}, hw = cross(I.h, x.a);
    return Six{plus(detail::inertia_times(I.J, x.a), cross(I.h, x.b)),
               {mv[0] - hw[0], mv[1] - hw[1], mv[2] - hw[2]}};
  };
  struct Rate {  // B summed: İ's J̇ and μ (İ's ḣ = ω × h + m v is μ's linear part m v − h × ω)
    std::array<S, 6> Jdot;
    Six momentum;
  };
  // B x = İ x + x ×* μ, İ x = (J̇ x_ω + ḣ × x_v, x_ω × ḣ): with ḣ = μ_v the x_v terms cancel,
  // B x = (J̇ x_ω + x_ω × μ_ω, 2 x_ω × μ_v).
  auto apply = [](const Rate& D, const Six& x) {
    const Vec3<S> l = cross(x.a, D.momentum.b);
    return Six{plus(detail::inertia_times(D.Jdot, x.a), cross(x.a, D.momentum.a)), plus(l, l)};
  };
  // Bᵀ s, as a force: s · (B x) = x_ω · (J̇ s_ω − s_ω × μ_ω + 2 μ_v × s_v); its linear part is 0,
  // so only this angular part is kept.
  auto apply_transposed = [](const Rate& D, const Six& s) {
    const Vec3<S> l = cross(D.momentum.b, s.b);
    return plus(minus(detail::inertia_times(D.Jdot, s.a), cross(s.a, D.momentum.a)), plus(l, l));
  };
  // Moving the point by d (the new point minus the old): a motion's linear part becomes
  // v + ω × d, a force's moment n − d × f; an inertia's h − m d and
  // J − 2 (h·d) 1 + h dᵀ + d hᵀ + m (|d|² 1 − d dᵀ) (about the new point; İ the same with m = 0).
  auto motion_to = [&](const Six& x, const Vec3<S>& d) {
    return Six{x.a, plus(x.b, cross(x.a, d))};
  };
  auto force_to = [&](const Six& f, const Vec3<S>& d) {
    return Six{minus(f.a, cross(d, f.b)), f.b};
  };
  auto moved = [&](const std::array<S, 6>& J, const Vec3<S>& h, const S* m, const Vec3<S>& d) {
    const S hd = h[0] * d[0] + h[1] * d[1] + h[2] * d[2];
    const S dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    auto entry = [&](int x, int y) {
      S e = detail::sym(J, x, y) + h[x] * d[y] + d[x] * h[y];
      if (m) e = e - *m * (d[x] * d[y]);
      if (x == y) e = e - (hd + hd);
      if (m && x == y) e = e + *m * dd;
      return e;
    };
    return detail::sym_of<S>(entry);
  };

  // Each link's point: the origin of the link that ends its unbranched path (children follow
  // their parents, so walking backwards finds every only child's point first).
  std::array<int, N> children{}, only_child{};
  for (std::size_t k = 0; k < N; ++k)
    if (links[k].parent >= 0) ++children[links[k].parent], only_child[links[k].parent] = int(k);
  std::array<std::size_t, N> at{};
  for (std::size_t k = N; k-- > 0;) at[k] = children[k] == 1 ? at[only_child[k]] : k;

  const std::array<Transform<S>, N> world = tree_placements(links, q);
  auto offset = [&](std::size_t to, std::size_t from) {  // point at[to] minus point at[from]
    return minus(world[at[to]].translation, world[at[from]].translation);
  };
  // Each velocity's motion per unit rate (its column of the tree's motion subspace): a joint's
  // one; a free root's six, (0, e_m) for the world-axes velocity of its origin and the line
  // through its origin along R e_m for its angular velocity in root axes.
  struct Column {
    std::size_t link;
    std::size_t index;  // in v
    Six s;
    bool free_linear, free_angular;
  };
  std::array<Column, N + 5> columns{};
  std::size_t count = 0;
  const std::array<int, N> velocity = detail::velocity_offsets(links);
  std::array<Six, N> v{}, a{}, F{};
  std::array<Six, N> v_parent, a_parent;
  Six turning{zero, zero};  // a free root's angular part of its velocity, Σ S_m ω_m
  std::array<Inertia, N> IC;
  std::array<Rate, N> BC;
  for (std::size_t k = 0; k < N; ++k) {  // outward: motions; each link's inertia, force and B
    const TreeLink<S>& l = links[k];
    const int p = l.parent;
    const bool moved_point = p >= 0 && at[p] != at[k];
    v_parent[k] = p < 0 ? Six{zero, zero} : moved_point ? motion_to(v[p], offset(k, p)) : v[p];
    a_parent[k] = p < 0 ? Six{zero, {S(0), S(0), gravity}}
                        : moved_point ? motion_to(a[p], offset(k, p)) : a[p];
    const Vec3<S> r = minus(world[k].translation, world[at[k]].translation);  // from the point
    if (l.free) {
      // Moving x or q's rotation moves the whole tree rigidly, these columns with it but the
      // world-fixed (0, e_m): the root acts as a joint whose parent translates at (0, ẋ) and
      // accelerates at (0, g + ẍ) — the spatial acceleration (0, ẍ) + (0, ẋ) × ω of the origin.
      const std::size_t c = static_cast<std::size_t>(velocity[k]);
      const Six along_x{zero, {qd[c], qd[c + 1], qd[c + 2]}};
      v_parent[k] = along_x;
      a_parent[k] = sum(a_parent[k], Six{zero, {qdd[c], qdd[c + 1], qdd[c + 2]}});
      const Rot3<S>& R = world[k].rotation;
      Six turning_rate{zero, zero};
      for (std::size_t m = 0; m < 3; ++m) {
        Vec3<S> e{S(0), S(0), S(0)};
        e[m] = S(1);
        columns[count++] = {k, c + m, Six{zero, e}, true, false};
      }
      for (std::size_t m = 0; m < 3; ++m) {
        const Vec3<S> axis{R[3 * m], R[3 * m + 1], R[3 * m + 2]};
        const Six s{axis, cross(r, axis)};
        columns[count++] = {k, c + 3 + m, s, false, true};
        turning = sum(turning, scale(s, qd[c + 3 + m]));
        turning_rate = sum(turning_rate, scale(s, qdd[c + 3 + m]));
      }
      v[k] = sum(along_x, turning);
      a[k] = sum(sum(a_parent[k], turning_rate), cross_motion(along_x, turning));
    } else {
      v[k] = v_parent[k];
      a[k] = a_parent[k];
      if (l.coordinate >= 0) {
        const auto unit = detail::unit_axis(l.axis).u;
        const Vec3<S> axis = rotate(world[k].rotation, Vec3<S>{S(unit[0]), S(unit[1]), S(unit[2])});
        const Six s = l.prismatic ? Six{zero, axis} : Six{axis, cross(r, axis)};
        const std::size_t j = static_cast<std::size_t>(velocity[k]);
        columns[count++] = {k, j, s, false, false};
        // v_k × S q̇ = q̇ (v_λ × S): u_j of the columns below, formed once for both.
        v[k] = sum(v[k], scale(s, qd[j]));
        a[k] = sum(a[k], sum(scale(s, qdd[j]), scale(cross_motion(v_parent[k], s), qd[j])));
      }
    }
    const Rot3<S> R = multiply(world[k].rotation, l.inertial.rotation);
    const Vec3<S> c = plus(r, rotate(world[k].rotation, l.inertial.translation));
    const std::array<S, 6> Jc = detail::rotated_inertia(R, l.inertia);
    const Vec3<S> h{l.mass * c[0], l.mass * c[1], l.mass * c[2]};
    const S hc = h[0] * c[0] + h[1] * c[1] + h[2] * c[2];
    auto J = [&](int x, int y) { return (x == y ? Jc[x] + hc : detail::sym(Jc, x, y)) - h[x] * c[y]; };
    IC[k] = {l.mass, h, detail::sym_of<S>(J)};
    const Six momentum = times(IC[k], v[k]);
    F[k] = sum(times(IC[k], a[k]), cross_force(v[k], momentum));
    // İ = v ×* I − I v×: J̇ = ω× J − J ω× − v hᵀ − h vᵀ + 2 (h · v) 1 and ḣ = ω × h + m v, with
    // ω× J − J ω× = P + Pᵀ for P = ω× J.
    const Vec3<S>& om = v[k].a;
    const Vec3<S>& vo = v[k].b;
    std::array<Vec3<S>, 3> P;  // P's columns
    for (int y = 0; y < 3; ++y)
      P[y] = cross(om, Vec3<S>{detail::sym(IC[k].J, 0, y), detail::sym(IC[k].J, 1, y),
                               detail::sym(IC[k].J, 2, y)});
    const S hv = h[0] * vo[0] + h[1] * vo[1] + h[2] * vo[2];
    auto Jdot = [&](int x, int y) {
      const S e = P[y][x] + P[x][y] - h[x] * vo[y] - vo[x] * h[y];
      return x == y ? e + (hv + hv) : e;
    };
    BC[k] = {detail::sym_of<S>(Jdot), momentum};
  }
  for (std::size_t k = N; k-- > 0;) {  // inward: the subtrees' sums, about the parent's point
    const int p = links[k].parent;
    if (p < 0) continue;
    Inertia I = IC[k];
    Rate D = BC[k];
    Six f = F[k];
    if (at[p] != at[k]) {
      const Vec3<S> d = offset(p, k);
      I.J = moved(I.J, I.h, &I.m, d);
      I.h = minus(I.h, {I.m * d[0], I.m * d[1], I.m * d[2]});
      D.Jdot = moved(D.Jdot, D.momentum.b, nullptr, d);  // ḣ = μ_v
      D.momentum = force_to(D.momentum, d);
      f = force_to(f, d);
    }
    IC[p].m = IC[p].m + I.m;
    IC[p].h = plus(IC[p].h, I.h);
    for (int x = 0; x < 6; ++x) IC[p].J[x] = IC[p].J[x] + I.J[x];
    for (int x = 0; x < 6; ++x) BC[p].Jdot[x] = BC[p].Jdot[x] + D.Jdot[x];
    BC[p].momentum = sum(BC[p].momentum, D.momentum);
    F[p] = sum(F[p], f);
  }
  for (S& x : dtau_dq) x = S(0);
  for (S& x : dtau_dv) x = S(0);
  auto ancestor = [&](std::size_t j, std::size_t i) {  // link j is link i or above it
    for (int k = static_cast<int>(i); k >= 0; k = links[k].parent)
      if (static_cast<std::size_t>(k) == j) return true;
    return false;
  };
  for (std::size_t cj = 0; cj < count; ++cj) {
    const Column& J = columns[cj];
    const std::size_t j = J.link;
    const Six& sj_ = J.s;
    const Six u = cross_motion(v_parent[j], sj_);
    const Six w = sum(cross_motion(a_parent[j], sj_), cross_motion(v_parent[j], u));  // − u × v_λ
    const Six from_motion = sum(times(IC[j], w), apply(BC[j], u));
    const Six z = sum(cross_force(sj_, F[j]), from_motion);
    // Moving v_j adds 2 u_j + S_j × v_k to link k's acceleration; a free root's angular rates
    // also turn its other angular columns: + (Σ S_m ω_m) × S_j.
    const Six twice_u = J.free_angular ? sum(scale(u, S(2)), cross_motion(turning, sj_)) : scale(u, S(2));
    const Six y = sum(apply(BC[j], sj_), times(IC[j], twice_u));
    // Where the rows above need these vectors, the diagonal S_jᵀ (I_j^c w_j + B_j^c u_j),
    // S_jᵀ (B_j^c S_j + 2 I_j^c u_j) takes one dot product each (fewer operations than below).
    bool rows_above = false;
    for (int k = links[j].parent; k >= 0; k = links[k].parent) rows_above |= links[k].coordinate >= 0;
    for (std::size_t ci = 0; ci < count; ++ci) {
      const Column& I = columns[ci];
      const std::size_t i = I.link;
      S& dq = dtau_dq[I.index + nv * J.index];
      S& dv = dtau_dv[I.index + nv * J.index];
      if (i == j && (rows_above || I.free_angular)) {
        // The column itself, or a free root's angular column, which every move of the root
        // turns with the tree (the world-fixed linear ones take the row above's form below).
        dq = dot(I.s, from_motion);
        dv = dot(I.s, y);
      } else if (i == j && I.free_linear) {
        dq = dot(I.s, z);
        dv = dot(I.s, y);
      } else if (ancestor(j, i)) {  // i in j's subtree, or a root's own column: about i's point
        // B_i^cᵀ S_i has no linear part, and a move keeps a motion's angular part: u_j and S_j
        // enter by theirs.
        const bool across = at[i] != at[j];
        const Vec3<S> d = across ? offset(i, j) : zero;
        const Six wj = across ? motion_to(w, d) : w, tj = across ? motion_to(twice_u, d) : twice_u;
        const Vec3<S> row = apply_transposed(BC[i], I.s);  // B_i^cᵀ S_i
        const Six IS = times(IC[i], I.s);
        dq = dot(wj, IS) + dot3(u.a, row);
        dv = dot3(sj_.a, row) + dot(tj, IS);
      } else if (ancestor(i, j) && I.free_angular && at[i] != at[j]) {
        // About the root's point, where its angular columns (R e_m, 0) have three nonzeros: z and y
        // moved once per column there, not the three columns to each point below.
        const Vec3<S> d = offset(i, j);
        dq = dot(I.s, force_to(z, d));
        dv = dot(I.s, force_to(y, d));
      } else if (ancestor(i, j)) {  // about j's point
        const Six si = at[i] != at[j] ? motion_to(I.s, offset(j, i)) : I.s;
        dq = dot(si, z);
        dv = dot(si, y);
      }
    }
  }
  // τ and M last, so that ∂τ's operations come first where this is traced.
  for (std::size_t c = 0; c < count && !tau.empty(); ++c) {
    const Column& C = columns[c];
    tau[C.index] = dot(C.s, F[C.link]);
    if (!links[C.link].free && links[C.link].armature != 0.0)
      tau[C.index] = tau[C.index] + qdd[C.index] * S(links[C.link].armature);
  }
  for (S& x : mass) x = S(0);
  for (std::size_t cj = 0; cj < count && !mass.empty(); ++cj) {
    const Column& J = columns[cj];
    // i in j's subtree, about i's point: the columns come in link order, parents first
    for (std::size_t ci = cj; ci < count; ++ci) {
      const Column& I = columns[ci];
      if (!ancestor(J.link, I.link)) continue;
      const Six sj = at[I.link] != at[J.link] ? motion_to(J.s, offset(I.link, J.link)) : J.s;
      mass[I.index + nv * J.index] = mass[J.index + nv * I.index] = dot(sj, times(IC[I.link], I.s));
    }
    const TreeLink<S>& l = links[J.link];
    if (!l.free && l.armature != 0.0) mass[J.index + nv * J.index] = mass[J.index + nv * J.index] + S(l.armature);
  }
}

}  // namespace eom
