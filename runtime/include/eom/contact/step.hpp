// Stepping with contact (docs/CONTRACT.md §1, "Stepping with contact"): MuJoCo's semi-implicit
// Euler step over the generated kernels K (mass_matrix, forward_dynamics) and the scene of the
// model header Model (geoms, pairs, limits, friction loss, options, damping):
//   a₀ = K's forward dynamics, M = K's mass matrix at (q, v);
//   a  = eom::solve_constraints(M, a₀, eom::constraint_rows(q, v)), warm-started from the last
//        step's a where that is cheaper (as MuJoCo's warm start);
//   a  ← (M + h diag(damping))⁻¹ (M a₀ + Jᵀ f) where any velocity is damped (damping implicit);
//   v ← v + h a,  q ← q ⊕ h v (the free joint's quaternion turned by exp(h ω/2)),  t ← t + h,
// h = Model::solver_options.timestep. Caller-owned state and workspace, allocation-free.
#pragma once

#include <array>
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

// One step from (t, q, v) with the inputs u and parameters p held.
template <class K, class Model>
StepStatus contact_step(ContactStepper<K, Model>& s, double& t, std::span<double, K::nq> q,
                        std::span<double, K::nv> v, const double* u, const double* p) {
  constexpr int nq = K::nq, nv = K::nv;
  const double h = Model::solver_options.timestep;
  std::array<double, nv * nv> M;
  std::array<double, nv> a0;
  K::mass_matrix(q.data(), p, M.data());
  if (!K::forward_dynamics(t, q.data(), v.data(), u, p, a0.data())) return StepStatus::dynamics_failed;
  if (!constraint_rows<Model>(s.links, std::span<const double>(q.data(), nq),
                              std::span<const double>(v.data(), nv), s.rows, &s.unmodeled_pair))
    return StepStatus::unmodeled_pair;
  const std::array<double, nv> last = s.solution.qacc;
  bool solved = s.warm && solve_constraints<Model>(M, a0, s.rows, s.solution, &last);
  if (!solved) solved = solve_constraints<Model>(M, a0, s.rows, s.solution);  // cold, from a0
  s.warm = solved;
  if (!solved) return StepStatus::solver_failed;
  std::array<double, nv> a = s.solution.qacc;
  bool damped = false;
  for (double b : Model::damping) damped |= b > 0;
  if (damped) {  // MuJoCo's implicit damping: (M + h B) a = M a₀ + Jᵀ f
    alignas(64) std::array<double, nv * nv> H = M;  // as solve_constraints' (GCC 12, -O3 AVX)
    for (int i = 0; i < nv; ++i) H[i + nv * i] += h * Model::damping[i];
    std::array<double, nv> Jf;
    detail::M_times<nv>(M, a0.data(), a.data());
    detail::JT_times<Model>(s.rows, s.solution.force.data(), Jf.data());
    for (int i = 0; i < nv; ++i) a[i] += Jf[i];
    if (!linalg::cholesky<double, nv>(H)) return StepStatus::solver_failed;
    linalg::cholesky_solve<double, nv>(H, a.data());
  }
  for (int i = 0; i < nv; ++i) v[i] += h * a[i];
  integrate_configuration(layout_of<K>(), q.data(), v.data(), h, q.data());
  t += h;
  return StepStatus::ok;
}

}  // namespace eom
