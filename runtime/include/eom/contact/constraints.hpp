// The constraint rows of MuJoCo's soft-constraint model at a state (docs/CONTRACT.md §1,
// "Constraint rows"): equality constraints, friction loss and limits (of dofs or joints, then of
// fixed tendons) and contacts, each row
// a Jacobian row J, its position and margin, its regularization R (D = 1/R) and its reference
// acceleration aref, as MuJoCo 2.2's mj_makeConstraint and mj_referenceConstraint build them for
// a model whose header states the scene as data (eom/multibody/scene.hpp); eom/contact/solver.hpp
// finds the constrained acceleration from them. In double, allocation-free: the rows live in a
// caller-owned eom::ConstraintRows sized for the model's worst case.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <span>

#include "eom/contact/narrow_phase.hpp"
#include "eom/model/model.hpp"
#include "eom/multibody/frames.hpp"
#include "eom/multibody/scene.hpp"
#include "eom/multibody/tree.hpp"

namespace eom {

// A row's kind, numbered as MuJoCo's mjtConstraint.
enum class RowKind { equality = 0, friction_dof, friction_tendon, limit_joint, limit_tendon,
                     frictionless, pyramidal, elliptic };
// Whether a row is a contact's (its id then a contact's index).
constexpr bool is_contact(RowKind k) {
  return k == RowKind::frictionless || k == RowKind::pyramidal || k == RowKind::elliptic;
}

// Room for Model's rows and contacts at any state: every equality's rows, every friction loss,
// both sides of every limit, and every candidate pair's most contacts (eom::pair_contacts: one
// box–box pair may give several times a sphere's) with their most rows (pyramidal condim 6: 10).
template <class Model> struct ConstraintRows {
  static constexpr int nv = ModelInfo<Model>::nv;
  static constexpr int max_contacts = [] {
    int n = 0;
    for (const CollisionPair& p : Model::collision_pairs)
      n += pair_contacts(Model::geoms[p.geom1].shape, Model::geoms[p.geom2].shape);
    return std::max(n, 1);  // room for one where none can touch: no empty arrays
  }();
  static constexpr int equality_rows = [] {
    int n = 0;
    for (const EqualitySoftness& e : Model::equality_softness) n += e.rows;
    return n;
  }();
  static constexpr int tendon_rows = [] {  // a friction loss's row, a limit's two
    int n = 0;
    for (const auto& t : Model::tendons) n += (t.frictionloss > 0 ? 1 : 0) + (t.limited ? 2 : 0);
    return n;
  }();
  static constexpr int capacity = equality_rows + static_cast<int>(Model::friction_losses.size()) +
                                  2 * static_cast<int>(Model::joint_limits.size()) + tendon_rows +
                                  10 * max_contacts;

  // The contacts the pairs gave (MuJoCo's d->contact, every one, those left out of the rows
  // included), each with its pair and whether it has rows (false: within the gap, or between
  // two geoms that do not move).
  int ncontacts = 0;
  std::array<Contact, max_contacts> contacts;
  std::array<int, max_contacts> contact_pair;
  std::array<bool, max_contacts> contact_active;
  std::array<int, max_contacts> contact_row;  // its first row; −1: none (MuJoCo's efc_address)
  std::array<double, max_contacts> mu;  // the regularized cone's friction (MuJoCo's contact.mu)

  int rows = 0;
  std::array<RowKind, capacity> kind;
  std::array<int, capacity> id;  // the equality_softness entry, the friction loss's velocity, the
                                 // limit's entry, the tendon, the contact
  std::array<double, capacity * nv> J;  // row-major
  std::array<double, capacity> pos, margin, frictionloss, diag_approx, R, D, aref;
  std::array<double, capacity> aref_damping;  // B of aref = −B (J v) − K I (pos − margin)
};

namespace detail {

inline constexpr int disable_equality = 1 << 1, disable_frictionloss = 1 << 2,
                     disable_limit = 1 << 3, disable_contact = 1 << 4, disable_constraint = 1 << 0,
                     disable_refsafe = 1 << 11;

// MuJoCo's impedance d(x) and its slope at a row's position (getimpedance).
inline std::array<double, 2> impedance(const std::array<double, 5>& s, double pos, double margin) {
  if (s[0] == s[1] || s[2] <= 1e-15) return {0.5 * (s[0] + s[1]), 0.0};
  double x = (pos - margin) / s[2], sign = 1;
  if (x < 0) x = -x, sign = -1;
  if (x >= 1 || x <= 0) return {x >= 1 ? s[1] : s[0], 0.0};
  double y, slope;
  // xᵖ: MuJoCo's default power 2 as x·x (pow's correctly rounded result, without its cost)
  auto power = [](double x, double p) { return p == 2 ? x * x : p == 1 ? x : std::pow(x, p); };
  if (s[4] == 1) {
    y = x, slope = 1;
  } else if (x <= s[3]) {
    const double a = 1 / power(s[3], s[4] - 1);
    y = a * power(x, s[4]);
    slope = s[4] * a * power(x, s[4] - 1);
  } else {
    const double b = 1 / power(1 - s[3], s[4] - 1);
    y = 1 - b * power(1 - x, s[4]);
    slope = s[4] * b * power(1 - x, s[4] - 1);
  }
  return {s[0] + y * (s[1] - s[0]), slope * sign * (s[1] - s[0]) / s[2]};
}

}  // namespace detail

namespace detail {

// constraint_rows with the links' placements X at q made (tree_placements) and, where `pairs`
// is given, only those candidate pairs collided (indices into collision_pairs, ascending): what
// the step's derivatives take at a perturbed q, where few links and pairs move.
template <class Model, std::size_t N>
bool rows_at(const std::array<TreeLink<double>, N>& links, const std::array<Transform<double>, N>& X,
             In<double> q, In<double> v, ConstraintRows<Model>& out, int* unmodeled, const double* phi,
             const double* C, std::optional<std::span<const int>> pairs = std::nullopt) {
  constexpr int nv = ConstraintRows<Model>::nv, nc = ConstraintRows<Model>::equality_rows;
  const SolverOptions& options = Model::solver_options;
  const int disabled = options.disable_flags;
  out.ncontacts = out.rows = 0;
  if (disabled & detail::disable_constraint) return true;
  if (nc > 0 && (!phi || !C)) return false;

  // Contacts, as mj_collision lists them.
  if (!(disabled & detail::disable_contact)) {
    std::array<Transform<double>, Model::geoms.size()> placed;  // each geom once, not per pair
    for (std::size_t g = 0; g < placed.size(); ++g) {
      const Geom& x = Model::geoms[g];
      const Transform<double> on{x.rotation, x.position};
      placed[g] = x.link < 0 ? on : X[x.link] * on;
    }
    const int count = pairs ? static_cast<int>(pairs->size()) : static_cast<int>(Model::collision_pairs.size());
    for (int i = 0; i < count; ++i) {
      const int k = pairs ? (*pairs)[i] : i;
      const CollisionPair& pair = Model::collision_pairs[k];
      const Geom &a = Model::geoms[pair.geom1], &b = Model::geoms[pair.geom2];
      const Transform<double>& xa = placed[pair.geom1];
      const Transform<double>& xb = placed[pair.geom2];
      const int n = collide(a, xa, b, xb, pair.margin, out.contacts.data() + out.ncontacts);
      if (n < 0) {  // unmodeled: only where MuJoCo's bounding tests cannot rule it out (collide
                    // applied the spheres' already; here a plane's distance to the other's centre)
        const Vec3<double> d = detail::minus(xb.translation, xa.translation);
        const bool apart = a.shape == Shape::plane && b.rbound > 0 &&
                           detail::dot(detail::z_axis(xa), d) > pair.margin + b.rbound;
        if (apart) continue;
        if (unmodeled) *unmodeled = k;
        out.ncontacts = 0;
        return false;
      }
      for (int c = out.ncontacts; c < out.ncontacts + n; ++c) {
        out.contact_pair[c] = k;
        out.contact_row[c] = -1;
        out.contact_active[c] = out.contacts[c].dist < pair.margin - pair.gap &&
                                (a.link >= 0 || b.link >= 0);
      }
      out.ncontacts += n;
    }
  }

  // A row of J (nv entries) at the end, and its data.
  auto add = [&](RowKind kind, int id, double pos, double margin, double loss, double dA) {
    const int r = out.rows++;
    out.kind[r] = kind, out.id[r] = id, out.pos[r] = pos, out.margin[r] = margin;
    out.frictionloss[r] = loss, out.diag_approx[r] = dA;
    double* row = out.J.data() + static_cast<std::size_t>(r) * nv;
    std::fill(row, row + nv, 0.0);
    return row;
  };
  if (!(disabled & detail::disable_equality))  // row i of φ and C; a weld's rotation rows of C
    for (int e = 0; e < static_cast<int>(Model::equality_softness.size()); ++e) {  // scaled
      const EqualitySoftness& x = Model::equality_softness[e];
      for (int i = x.first; i < x.first + x.rows; ++i) {
        double* row = add(RowKind::equality, e, phi[i], 0, 0, x.inverse_weight);
        const double scale = x.rows == 6 && i >= x.first + 3 ? x.torquescale : 1.0;
        for (int j = 0; j < nv; ++j) row[j] = scale * C[i + nc * j];
      }
    }
  // a fixed tendon's Jacobian row, times `sign`, into row (MuJoCo's ten_J: coefficients summed)
  auto tendon_row = [](const auto& t, double sign, double* row) {
    for (int k = 0; k < t.count; ++k) row[t.joints[k].velocity] += sign * t.joints[k].coef;
  };
  constexpr int ntendons = static_cast<int>(Model::tendons.size());
  if (!(disabled & detail::disable_frictionloss)) {  // the dofs' then the tendons', as MuJoCo
    for (const FrictionLoss& f : Model::friction_losses)
      add(RowKind::friction_dof, f.velocity, 0, 0, f.loss, f.inverse_weight)[f.velocity] = 1;
    for (int k = 0; k < ntendons; ++k) {
      const auto& t = Model::tendons[k];
      if (t.frictionloss > 0)
        tendon_row(t, 1, add(RowKind::friction_tendon, k, 0, 0, t.frictionloss, t.inverse_weight));
    }
  }
  if (!(disabled & detail::disable_limit)) {  // the joints' then the tendons', as MuJoCo
    for (int k = 0; k < static_cast<int>(Model::joint_limits.size()); ++k) {
      const JointLimit& l = Model::joint_limits[k];
      const double value = q[l.coordinate];
      for (int side : {-1, 1}) {  // lower: q − lower, J = +1; upper: upper − q, J = −1
        const double dist = side * ((side < 0 ? l.lower : l.upper) - value);
        if (dist < l.margin)
          add(RowKind::limit_joint, k, dist, l.margin, 0, l.inverse_weight)[l.velocity] = -side;
      }
    }
    for (int k = 0; k < ntendons; ++k) {
      const auto& t = Model::tendons[k];
      if (!t.limited) continue;
      double length = 0;  // MuJoCo's ten_length, summed in its order
      for (int i = 0; i < t.count; ++i) length += t.joints[i].coef * q[t.joints[i].coordinate];
      for (int side : {-1, 1}) {  // as a joint's, along the tendon
        const double dist = side * ((side < 0 ? t.lower : t.upper) - length);
        if (dist < t.margin) tendon_row(t, -side, add(RowKind::limit_tendon, k, dist, t.margin, 0, t.inverse_weight));
      }
    }
  }
  std::array<double, 6 * nv> Ja, Jb;
  std::array<std::array<double, nv>, 6> jac;  // the contact frame's rows of J(b) − J(a), condim of them
  const int pyramidal = options.cone == 0;
  for (int c = 0; c < out.ncontacts; ++c) {
    if (!out.contact_active[c]) continue;
    const Contact& con = out.contacts[c];
    const CollisionPair& pair = Model::collision_pairs[out.contact_pair[c]];
    const int dim = pair.condim;
    auto point_jacobian = [&](int link, std::array<double, 6 * nv>& J) {
      if (link < 0) return J.fill(0);  // on the world
      tree_frame_jacobian<double>(links, X, link, con.pos, q, J);
    };
    point_jacobian(Model::geoms[pair.geom1].link, Ja);
    point_jacobian(Model::geoms[pair.geom2].link, Jb);
    for (int k = 0; k < dim; ++k) {  // frame row k (k < 3: translation; else rotation, row k − 3)
      const double* axis = con.frame.data() + 3 * (k % 3);
      const int at = k < 3 ? 0 : 3;
      for (int j = 0; j < nv; ++j) {
        double s = 0;
        for (int i = 0; i < 3; ++i) s += axis[i] * (Jb[at + i + 6 * j] - Ja[at + i + 6 * j]);
        jac[k][j] = s;
      }
    }
    const double include = pair.margin - pair.gap;
    const double tran = pair.inverse_weight[0], rot = pair.inverse_weight[1];
    out.contact_row[c] = out.rows;
    if (dim == 1) {
      std::copy_n(jac[0].data(), nv, add(RowKind::frictionless, c, con.dist, include, 0, tran));
    } else if (pyramidal) {
      for (int k = 1; k < dim; ++k) {
        const double f = pair.friction[k - 1];
        const double dA = tran + f * f * (k - 1 < 2 ? tran : rot);
        for (double sign : {1.0, -1.0}) {
          double* row = add(RowKind::pyramidal, c, con.dist, include, 0, dA);
          for (int j = 0; j < nv; ++j) row[j] = jac[0][j] + sign * f * jac[k][j];
        }
      }
    } else {
      for (int k = 0; k < dim; ++k)
        std::copy_n(jac[k].data(), nv,
                    add(RowKind::elliptic, c, k == 0 ? con.dist : 0, k == 0 ? include : 0, 0,
                        k < 3 ? tran : rot));
    }
  }

  // R, and the reference acceleration's stiffness K, damping B and impedance I (mj_makeImpedance).
  std::array<double, ConstraintRows<Model>::capacity> K, B, I;  // rows [0, out.rows) only
  for (int r = 0; r < out.rows;) {
    Softness s;
    int dim = 1;
    double at = out.pos[r];  // where the impedance is taken: a connect's or weld's residual norm
    const RowKind kind = out.kind[r];
    if (kind == RowKind::equality) {
      const EqualitySoftness& x = Model::equality_softness[out.id[r]];
      s = x.softness;
      if (x.rows > 1) {
        dim = x.rows, at = 0;
        for (int j = 0; j < dim; ++j) {
          const double e = (j < 3 ? 1.0 : x.torquescale) * out.pos[r + j];
          at += e * e;
        }
        at = std::sqrt(at);
      }
    } else if (kind == RowKind::friction_dof) {
      for (const FrictionLoss& f : Model::friction_losses)
        if (f.velocity == out.id[r]) s = f.softness;
    } else if (kind == RowKind::friction_tendon) {
      s = Model::tendons[out.id[r]].friction_softness;
    } else if (kind == RowKind::limit_joint) {
      s = Model::joint_limits[out.id[r]].softness;
    } else if (kind == RowKind::limit_tendon) {
      s = Model::tendons[out.id[r]].softness;
    } else {
      s = Model::collision_pairs[out.contact_pair[out.id[r]]].softness;
      const int condim = Model::collision_pairs[out.contact_pair[out.id[r]]].condim;
      dim = kind == RowKind::elliptic ? condim : kind == RowKind::pyramidal ? 2 * (condim - 1) : 1;
    }
    auto& ref = s.solref;
    auto& imp = s.solimp;
    if ((ref[0] > 0) != (ref[1] > 0)) ref = Softness{}.solref;  // mixed: MuJoCo's default
    if (!(disabled & detail::disable_refsafe) && ref[0] > 0)
      ref[0] = std::max(ref[0], 2 * options.timestep);
    for (int k : {0, 1, 3}) imp[k] = std::min(0.9999, std::max(0.0001, imp[k]));
    imp[2] = std::max(0.0, imp[2]);
    imp[4] = std::max(1.0, imp[4]);
    const auto [d, slope] = detail::impedance(imp, at, out.margin[r]);
    (void)slope;
    for (int j = r; j < r + dim; ++j) {
      out.R[j] = std::max(1e-15, (1 - d) * out.diag_approx[j] / d);
      const bool friction = out.kind[j] == RowKind::friction_dof || out.kind[j] == RowKind::friction_tendon ||
                            (out.kind[j] == RowKind::elliptic && j > r);
      K[j] = friction ? 0
             : ref[0] > 0 ? 1 / std::max(1e-15, imp[1] * imp[1] * ref[0] * ref[0] * ref[1] * ref[1])
                          : -ref[0] / std::max(1e-15, imp[1] * imp[1]);
      B[j] = ref[1] > 0 ? 2 / std::max(1e-15, imp[1] * ref[0]) : -ref[1] / std::max(1e-15, imp[1]);
      I[j] = d;
    }
    r += dim;
  }
  for (int r = 0; r < out.rows;) {  // frictional contacts: R of the friction rows, the cone's mu
    const RowKind kind = out.kind[r];
    if (kind != RowKind::pyramidal && kind != RowKind::elliptic) {
      ++r;
      continue;
    }
    const int c = out.id[r];
    const CollisionPair& pair = Model::collision_pairs[out.contact_pair[c]];
    const auto& f = pair.friction;
    out.R[r + 1] = out.R[r] / std::max(1e-15, options.impratio);
    out.mu[c] = f[0] * std::sqrt(out.R[r + 1] / out.R[r]);
    if (kind == RowKind::elliptic) {
      for (int j = 1; j < pair.condim - 1; ++j)
        out.R[r + j + 1] = out.R[r + 1] * f[0] * f[0] / (f[j] * f[j]);
      r += pair.condim;
    } else {
      const double common = 2 * out.mu[c] * out.mu[c] * out.R[r];
      for (int j = 0; j < 2 * (pair.condim - 1); ++j) out.R[r + j] = common;
      r += 2 * (pair.condim - 1);
    }
  }
  for (int r = 0; r < out.rows; ++r) {
    out.D[r] = 1 / out.R[r];
    out.diag_approx[r] = out.R[r] * I[r] / (1 - I[r]);  // as MuJoCo leaves it
    double velocity = 0;
    const double* row = out.J.data() + static_cast<std::size_t>(r) * nv;
    for (int j = 0; j < nv; ++j) velocity += row[j] * v[j];
    out.aref[r] = -B[r] * velocity - K[r] * I[r] * (out.pos[r] - out.margin[r]);
    out.aref_damping[r] = B[r];
  }
  return true;
}

}  // namespace detail

// Model's constraint rows at (q, v) on its tree `links` (eom::tree_of<Model>): contacts from its
// collision_pairs through eom::collide, then the rows in MuJoCo's order (equality constraints,
// friction loss, limits, contacts), then R, D and aref. The equality rows are the model's
// constraints: phi its residual φ(q) and C its Jacobian (nc × nv, column-major), the kernels'
// constraint_residual and constraint_jacobian at q; where Model has equality_softness entries
// they are needed (else the call returns false, with no rows). A pair of shapes collide() does
// not model gives nothing where MuJoCo's bounding-sphere tests (rbound) rule out a contact; else
// the function returns false, with no rows, the pair's index in *unmodeled.
template <class Model, std::size_t N>
bool constraint_rows(const std::array<TreeLink<double>, N>& links, In<double> q, In<double> v,
                     ConstraintRows<Model>& out, int* unmodeled = nullptr,
                     const double* phi = nullptr, const double* C = nullptr) {
  return detail::rows_at<Model>(links, tree_placements(links, q), q, v, out, unmodeled, phi, C);
}

}  // namespace eom
