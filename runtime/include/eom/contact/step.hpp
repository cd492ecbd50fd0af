// Stepping with contact (docs/CONTRACT.md §1, "Stepping with contact"): mj_step of MuJoCo 2.2 over
// the generated kernels K (mass_matrix, forward_dynamics) and the scene of the model header Model
// (geoms, pairs, limits, friction loss, options, damping), by the model's integrator
// (Model::solver_options.integrator, MuJoCo's <option integrator>). At a state (t, q, v):
//   a₀ = K's forward dynamics, M = K's mass matrix;
//   a  = eom::solve_constraints(M, a₀, eom::constraint_rows(q, v)), warm-started from the last
//        solve's a where that is cheaper (as MuJoCo's warm start).
// A model with constraints (K::nc > 0: MJCF equalities, Model::equality_softness) has them as
// MuJoCo's soft equality rows, not held exactly: a₀ = −M⁻¹ τ, τ = K's inverse dynamics at
// v̇ = 0 (the forces without constraint forces), and the rows from K's constraint_residual and
// constraint_jacobian (K must have these three kernels besides mass_matrix).
// Euler (0), semi-implicit:
//   a  ← (M + h diag(damping))⁻¹ (M a₀ + Jᵀ f) where any velocity is damped (damping implicit);
//   v ← v + h a,  q ← q ⊕ h v (the free joint's quaternion turned by exp(h ω/2)),  t ← t + h.
// RK4 (1), MuJoCo's mj_RungeKutta: the classic tableau on x = (q, v), ẋ = (v, a), each of its
// four stages a full evaluation at its own state and time (collision, rows, a warm-started
// solve; damping explicit, inside a₀); stage states q₀ ⊕ h cᵢ vᵢ₋₁ with unit quaternions; the
// result q₀ ⊕ h Σ bᵢ vᵢ, v₀ + h Σ bᵢ aᵢ, t + h. The rows and solution left in the stepper are
// the last stage's, as MuJoCo's mjData after mj_step.
// h = Model::solver_options.timestep. Caller-owned state and workspace, allocation-free.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "eom/contact/constraints.hpp"
#include "eom/contact/solver.hpp"
#include "eom/model/free_joint.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

// Why a step failed; the state is left as it was.
enum class StepStatus { ok, dynamics_failed, unmodeled_pair, solver_failed };

// The workspace of a contact step: the tree (the scene's geometry), the rows and the solution.
template <class K, class Model> struct ContactStepper {
  static constexpr int nq = K::nq, nv = K::nv;
  static_assert(nv == ConstraintRows<Model>::nv, "eom::ContactStepper: K and Model disagree on nv");
  std::array<TreeLink<double>, Model::link_count> links = tree_of<Model, double>(Model::parameter_values);
  ConstraintRows<Model> rows;
  ConstraintSolution<Model> solution;
  int unmodeled_pair = -1;  // where a step returned unmodeled_pair: the pair's index
  bool warm = false;        // the next step's solver starts from solution.qacc where cheaper
};

namespace detail {

// The smooth dynamics at (t, q, v): M, the unconstrained acceleration a₀ and, with equality
// constraints (K::nc > 0), their residual φ and Jacobian C for the rows.
template <class K>
StepStatus smooth_dynamics(double t, const double* q, const double* v, const double* u,
                           const double* p, std::array<double, K::nv * K::nv>& M,
                           std::array<double, K::nv>& a0,
                           std::array<double, std::max(K::nc, 1)>& phi,
                           std::array<double, std::max(K::nc, 1) * K::nv>& C) {
  constexpr int nv = K::nv, nc = K::nc;
  K::mass_matrix(q, p, M.data());
  if constexpr (nc > 0) {  // a₀ without the constraints: M a₀ = −τ(v̇ = 0)
    static_assert(requires { K::inverse_dynamics(t, q, v, q, u, p, a0.data()); } &&
                      requires { K::constraint_residual(q, p, phi.data()); } &&
                      requires { K::constraint_jacobian(q, p, C.data()); },
                  "eom::contact_step: a model with equality constraints needs the kernels "
                  "inverse_dynamics, constraint_residual and constraint_jacobian (add_eom_model "
                  "KERNELS), besides mass_matrix");
    const std::array<double, nv> zero{};
    K::inverse_dynamics(t, q, v, zero.data(), u, p, a0.data());
    alignas(64) std::array<double, nv * nv> L = M;
    if (!linalg::cholesky<double, nv>(L)) return StepStatus::dynamics_failed;
    for (double& x : a0) x = -x;
    linalg::cholesky_solve<double, nv>(L, a0.data());
    for (double x : a0)
      if (!std::isfinite(x)) return StepStatus::dynamics_failed;
    K::constraint_residual(q, p, phi.data());
    K::constraint_jacobian(q, p, C.data());
  } else if (!K::forward_dynamics(t, q, v, u, p, a0.data())) {
    return StepStatus::dynamics_failed;
  }
  return StepStatus::ok;
}

// The constrained acceleration at (t, q, v) into s.rows and s.solution (what MuJoCo's mj_forward
// gives mj_step's integrators), with M and a₀ out; the warm start from s.solution.qacc.
template <class K, class Model>
StepStatus constrained_acceleration(ContactStepper<K, Model>& s, double t, const double* q,
                                    const double* v, const double* u, const double* p,
                                    std::array<double, K::nv * K::nv>& M,
                                    std::array<double, K::nv>& a0) {
  constexpr int nq = K::nq, nv = K::nv, nc = K::nc;
  // A constraint that is not one of the scene's equalities could not be stepped: MuJoCo's solver
  // would not hold it.
  static_assert(nc == ConstraintRows<Model>::equality_rows,
                "eom::contact_step: the model's constraints are not its scene's equality "
                "constraints (Model::equality_softness)");
  std::array<double, std::max(nc, 1)> phi{};
  std::array<double, std::max(nc, 1) * nv> C{};
  if (const StepStatus status = smooth_dynamics<K>(t, q, v, u, p, M, a0, phi, C);
      status != StepStatus::ok)
    return status;
  if (!constraint_rows<Model>(s.links, std::span<const double>(q, nq), std::span<const double>(v, nv),
                              s.rows, &s.unmodeled_pair, phi.data(), C.data()))
    return StepStatus::unmodeled_pair;
  const std::array<double, nv> last = s.solution.qacc;
  bool solved = s.warm && solve_constraints<Model>(M, a0, s.rows, s.solution, &last);
  if (!solved) solved = solve_constraints<Model>(M, a0, s.rows, s.solution);  // cold, from a0
  s.warm = solved;
  return solved ? StepStatus::ok : StepStatus::solver_failed;
}

// Whether any of Model's velocities is damped (then Euler's damping is implicit).
template <class Model> constexpr bool damped() {
  for (double b : Model::damping)
    if (b > 0) return true;
  return false;
}

// MuJoCo's implicit damping (mj_Euler): a = (M + h diag(damping))⁻¹ (M a₀ + Jᵀ f) from the
// solution in s, where any velocity is damped, H left holding M + h B's Cholesky factor (for
// the step's Jacobians); else the solution's a, H untouched. False where M + h B does not
// factor.
template <class K, class Model>
bool damped_acceleration(const ContactStepper<K, Model>& s, const std::array<double, K::nv * K::nv>& M,
                         const std::array<double, K::nv>& a0, std::array<double, K::nv>& a,
                         std::array<double, K::nv * K::nv>& H) {
  constexpr int nv = K::nv;
  const double h = Model::solver_options.timestep;
  a = s.solution.qacc;
  if constexpr (!damped<Model>()) return true;
  H = M;
  for (int i = 0; i < nv; ++i) H[i + nv * i] += h * Model::damping[i];
  std::array<double, nv> Jf;
  detail::M_times<nv>(M, a0.data(), a.data());
  detail::JT_times<Model>(s.rows, s.solution.force.data(), Jf.data());
  for (int i = 0; i < nv; ++i) a[i] += Jf[i];
  if (!linalg::cholesky<double, nv>(H)) return false;
  linalg::cholesky_solve_overlapped<double, nv>(H, a.data());
  return true;
}

// The semi-implicit Euler update: v ← v + h a, q ← q ⊕ h v, t ← t + h.
template <class K>
void euler_update(double h, const std::array<double, K::nv>& a, double& t,
                  std::span<double, K::nq> q, std::span<double, K::nv> v) {
  for (int i = 0; i < K::nv; ++i) v[i] += h * a[i];
  integrate_configuration(layout_of<K>(), q.data(), v.data(), h, q.data());
  t += h;
}

// MuJoCo's semi-implicit Euler step (mj_Euler).
template <class K, class Model>
StepStatus euler_contact_step(ContactStepper<K, Model>& s, double& t, std::span<double, K::nq> q,
                              std::span<double, K::nv> v, const double* u, const double* p) {
  constexpr int nv = K::nv;
  const double h = Model::solver_options.timestep;
  std::array<double, nv * nv> M;
  std::array<double, nv> a0;
  const StepStatus status = constrained_acceleration(s, t, q.data(), v.data(), u, p, M, a0);
  if (status != StepStatus::ok) return status;
  std::array<double, nv> a;
  alignas(64) std::array<double, nv * nv> H;  // as solve_constraints' (GCC 12, -O3 AVX)
  if (!damped_acceleration(s, M, a0, a, H)) return StepStatus::solver_failed;
  euler_update<K>(h, a, t, q, v);
  return StepStatus::ok;
}

// MuJoCo's RK4 step (mj_RungeKutta with its tableau), the state written only once all four
// stages have succeeded.
template <class K, class Model>
StepStatus rk4_contact_step(ContactStepper<K, Model>& s, double& t, std::span<double, K::nq> q,
                            std::span<double, K::nv> v, const double* u, const double* p) {
  constexpr int nq = K::nq, nv = K::nv;
  constexpr Layout layout = layout_of<K>();
  const double h = Model::solver_options.timestep;
  // Stage i ≥ 1 starts from stage i − 1's rates scaled by c[i − 1]: the tableau's A holds only
  // its subdiagonal (½, ½, 1), so cᵢ = Aᵢ,ᵢ₋₁; b the weights.
  constexpr std::array<double, 3> c{0.5, 0.5, 1.0};
  constexpr std::array<double, 4> b{1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0};
  std::array<std::array<double, nq>, 4> X;     // the stages' q
  std::array<std::array<double, nv>, 4> V, A;  // their v and a
  std::array<double, nv * nv> M;
  std::array<double, nv> a0, dq, dv;
  std::copy(q.begin(), q.end(), X[0].begin());
  std::copy(v.begin(), v.end(), V[0].begin());
  for (int i = 0; i < 4; ++i) {
    if (i > 0) {  // x₀ ⊕ h cᵢ ẋᵢ₋₁, its quaternions back on the unit sphere (as mj_integratePos)
      for (int j = 0; j < nv; ++j) dq[j] = c[i - 1] * V[i - 1][j], dv[j] = c[i - 1] * A[i - 1][j];
      integrate_configuration(layout, X[0].data(), dq.data(), h, X[i].data());
      normalize_configuration(layout, X[i].data());
      for (int j = 0; j < nv; ++j) V[i][j] = V[0][j] + dv[j] * h;
    }
    const double stage_time = i == 0 ? t : t + c[i - 1] * h;
    const StepStatus status =
        constrained_acceleration(s, stage_time, X[i].data(), V[i].data(), u, p, M, a0);
    if (status != StepStatus::ok) return status;
    A[i] = s.solution.qacc;
  }
  dq.fill(0), dv.fill(0);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < nv; ++j) dq[j] += b[i] * V[i][j], dv[j] += b[i] * A[i][j];
  for (int j = 0; j < nv; ++j) v[j] += dv[j] * h;
  integrate_configuration(layout, X[0].data(), dq.data(), h, q.data());
  normalize_configuration(layout, q.data());
  t += h;
  return StepStatus::ok;
}

}  // namespace detail

// MuJoCo's mj_forward at (t, q, v) with u and p: the constrained acceleration into s.solution
// (qacc; each row's force, as MuJoCo's efc_force) and what it rests on into s.rows (the contacts:
// rows.ncontacts, rows.contacts[c] with its distance, position and frame, contact c's force in
// that frame by eom::contact_force(s.rows, s.solution, c)). The solver starts from the
// unconstrained acceleration, not from the stepper's last solution, so that what comes out is the
// state's alone; a contact_step from the same state then starts from it. Nothing else changes.
template <class K, class Model>
StepStatus contact_forward(ContactStepper<K, Model>& s, double t, std::span<const double, K::nq> q,
                           std::span<const double, K::nv> v, const double* u, const double* p) {
  std::array<double, K::nv * K::nv> M;
  std::array<double, K::nv> a0;
  s.warm = false;
  return detail::constrained_acceleration(s, t, q.data(), v.data(), u, p, M, a0);
}

// One step from (t, q, v) with the inputs u and parameters p held, by the model's integrator.
template <class K, class Model>
StepStatus contact_step(ContactStepper<K, Model>& s, double& t, std::span<double, K::nq> q,
                        std::span<double, K::nv> v, const double* u, const double* p) {
  constexpr int integrator = Model::solver_options.integrator;
  static_assert(integrator == 0 || integrator == 1,
                "eom::contact_step: the model's integrator is neither Euler (0) nor RK4 (1); "
                "MuJoCo's implicit integrator (2) is not supported");
  if constexpr (integrator == 1)
    return detail::rk4_contact_step<K, Model>(s, t, q, v, u, p);
  else
    return detail::euler_contact_step<K, Model>(s, t, q, v, u, p);
}

}  // namespace eom
