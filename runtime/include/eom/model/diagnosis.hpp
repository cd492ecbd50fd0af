// Why forward_dynamics failed at a state, as far as the kernels can tell: the kernel itself
// returns only false (docs/CONTRACT.md §3), so the runtime looks again, at the failing state, with
// the kernels it has (mass_matrix, constraint_jacobian): an input that is not finite, M indefinite
// (a negative pivot: the kinetic energy is negative along some velocity, e.g. a parameter that
// made a mass or an inertia negative), M singular (a zero pivot: a velocity that moves nothing),
// C M⁻¹ Cᵀ singular (the constraints lost rank), or else a result that is not finite. The pivot
// test and the order of the pivots are the kernels' own (eom/numeric/linalg.hpp, M factored in the order
// of the velocities), so the velocity named is the first whose pivot fails.
//
// The integrators note the diagnosis of the last failure of the dynamics on the calling thread
// (detail::note_dynamics_failure, on the failure path only: nothing is computed while the
// dynamics succeed), and eom::integrate reports it with Status::singular_dynamics
// (IntegrationResult::failure, failure_velocity).
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

enum class DynamicsFailure {
  none,                    // no failure (or not a failure of the dynamics)
  non_finite_input,        // t, q, v, u or p not finite
  indefinite_mass_matrix,  // M has a negative pivot (failure_velocity: which)
  singular_mass_matrix,    // M has a zero pivot, to the kernels' tolerance (failure_velocity)
  singular_constraints,    // M is fine, C M⁻¹ Cᵀ is singular
  non_finite_result,       // M (or q̈) not finite where the inputs are
  unclassified,            // forward_dynamics failed, and K has no mass_matrix to say why
};

constexpr const char* to_string(DynamicsFailure f) {
  switch (f) {
    case DynamicsFailure::none: return "none";
    case DynamicsFailure::non_finite_input: return "an input of forward_dynamics is not finite";
    case DynamicsFailure::indefinite_mass_matrix:
      return "the mass matrix is indefinite (a negative pivot: the kinetic energy is negative "
             "along some velocity; check masses, inertias and the parameters)";
    case DynamicsFailure::singular_mass_matrix:
      return "the mass matrix is singular (a zero pivot: a velocity that moves no mass)";
    case DynamicsFailure::singular_constraints:
      return "the constraints are singular (C M^-1 C' lost rank: a singular configuration)";
    case DynamicsFailure::non_finite_result: return "the mass matrix or the acceleration is not finite";
    case DynamicsFailure::unclassified:
      return "forward_dynamics failed (no mass_matrix kernel to tell why: add it to KERNELS)";
  }
  return "unknown";
}

struct DynamicsDiagnosis {
  DynamicsFailure failure = DynamicsFailure::none;
  int velocity = -1;  // the failing pivot's velocity index (M's failures), else −1
  double t = std::numeric_limits<double>::quiet_NaN();  // where the dynamics failed
};

// The diagnosis of forward_dynamics at (t, q, v, u, p), assumed to have failed there.
template <Dynamics K>
DynamicsDiagnosis diagnose_dynamics(double t, const double* q, const double* qd, const double* u,
                                    const double* p) noexcept {
  constexpr int nq = K::nq, nv = nv_of<K>, nc = K::nc;
  DynamicsDiagnosis d;
  d.t = t;
  bool finite = std::isfinite(t);
  for (int i = 0; i < nq; ++i) finite = finite && std::isfinite(q[i]);
  for (int i = 0; i < nv; ++i) finite = finite && std::isfinite(qd[i]);
  for (int i = 0; i < K::nu; ++i) finite = finite && std::isfinite(u[i]);
  for (int i = 0; i < K::np; ++i) finite = finite && std::isfinite(p[i]);
  if (!finite) {
    d.failure = DynamicsFailure::non_finite_input;
    return d;
  }
  if constexpr (HasMassMatrix<K>) {
    std::array<double, nv * nv> M;
    K::mass_matrix(q, p, M.data());
    const linalg::PivotFailure f = linalg::first_failing_pivot<nv>(M);
    using linalg::PivotProblem;
    if (f.problem != PivotProblem::none) {
      d.velocity = f.index;
      d.failure = f.problem == PivotProblem::indefinite ? DynamicsFailure::indefinite_mass_matrix
                  : f.problem == PivotProblem::singular ? DynamicsFailure::singular_mass_matrix
                                                        : DynamicsFailure::non_finite_result;
      return d;
    }
    if constexpr (nc > 0 && HasConstraintJacobian<K>) {
      std::array<double, nc * nv> C;
      K::constraint_jacobian(q, p, C.data());
      linalg::cholesky<double, nv>(M);  // factors: the pivot test passed above
      std::array<double, nv * nc> Y;    // M⁻¹ Cᵀ, column i for constraint i
      for (int i = 0; i < nc; ++i) {
        for (int j = 0; j < nv; ++j) Y[j + nv * i] = C[i + nc * j];
        linalg::cholesky_solve<double, nv>(M, Y.data() + nv * i);
      }
      std::array<double, nc * nc> S;
      for (int i = 0; i < nc; ++i)
        for (int k = 0; k < nc; ++k) {
          double s = 0;
          for (int j = 0; j < nv; ++j) s += C[i + nc * j] * Y[j + nv * k];
          S[i + nc * k] = s;
        }
      if (linalg::cholesky_failure<double, nc>(S) >= 0) {
        d.failure = DynamicsFailure::singular_constraints;
        return d;
      }
    }
    d.failure = DynamicsFailure::non_finite_result;
  } else {
    d.failure = DynamicsFailure::unclassified;
  }
  return d;
}

namespace detail {

// The calling thread's last noted failure of the dynamics (eom::integrate clears it first).
inline DynamicsDiagnosis& last_dynamics_failure() noexcept {
  static thread_local DynamicsDiagnosis d;
  return d;
}
template <Dynamics K>
void note_dynamics_failure(double t, const double* q, const double* qd, const double* u,
                           const double* p) noexcept {
  last_dynamics_failure() = diagnose_dynamics<K>(t, q, qd, u, p);
}

}  // namespace detail
}  // namespace eom
