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

#include <algorithm>
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
  invalid_argument,        // a contact kernel's s, kd, rho or restitution out of its range
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
    case DynamicsFailure::invalid_argument:
      return "an argument is out of its range (the contact set s, kd < 0, rho < 0, or the "
             "restitution outside [0, 1])";
  }
  return "unknown";
}

struct DynamicsDiagnosis {
  DynamicsFailure failure = DynamicsFailure::none;
  int velocity = -1;  // the failing pivot's velocity index (M's failures), else −1
  double t = std::numeric_limits<double>::quiet_NaN();  // where the dynamics failed
};

namespace detail {

template <class K>
bool inputs_finite(double t, const double* q, const double* qd, const double* u, const double* p) noexcept {
  bool finite = std::isfinite(t);
  for (int i = 0; i < K::nq; ++i) finite = finite && std::isfinite(q[i]);
  for (int i = 0; i < nv_of<K>; ++i) finite = finite && std::isfinite(qd[i]);
  for (int i = 0; i < K::nu; ++i) finite = finite && std::isfinite(u[i]);
  for (int i = 0; i < K::np; ++i) finite = finite && std::isfinite(p[i]);
  return finite;
}

// K's M at q, Cholesky-factored in place when it passes the pivot test; else false, with its
// failure and the failing velocity in d.
template <class K>
bool factor_mass_matrix(const double* q, const double* p, std::array<double, nv_of<K> * nv_of<K>>& M,
                        DynamicsDiagnosis& d) noexcept {
  K::mass_matrix(q, p, M.data());
  const linalg::PivotFailure f = linalg::first_failing_pivot<nv_of<K>>(M);
  using linalg::PivotProblem;
  if (f.problem != PivotProblem::none) {
    d.velocity = f.index;
    d.failure = f.problem == PivotProblem::indefinite ? DynamicsFailure::indefinite_mass_matrix
                : f.problem == PivotProblem::singular ? DynamicsFailure::singular_mass_matrix
                                                      : DynamicsFailure::non_finite_result;
    return false;
  }
  linalg::cholesky<double, nv_of<K>>(M);  // the pivot test passed above
  return true;
}

}  // namespace detail

// The diagnosis of forward_dynamics at (t, q, v, u, p), assumed to have failed there.
template <Dynamics K>
DynamicsDiagnosis diagnose_dynamics(double t, const double* q, const double* qd, const double* u,
                                    const double* p) noexcept {
  constexpr int nv = nv_of<K>, nc = K::nc;
  DynamicsDiagnosis d;
  d.t = t;
  if (!detail::inputs_finite<K>(t, q, qd, u, p)) {
    d.failure = DynamicsFailure::non_finite_input;
    return d;
  }
  if constexpr (HasMassMatrix<K>) {
    std::array<double, nv * nv> M;
    if (!detail::factor_mass_matrix<K>(q, p, M, d)) return d;
    if constexpr (nc > 0 && HasConstraintJacobian<K>) {
      std::array<double, nc * nv> C;
      K::constraint_jacobian(q, p, C.data());
      std::array<double, nv * nc> Y;  // M⁻¹ Cᵀ, column i for constraint i
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

// The diagnosis of contact_dynamics on set s (docs/CONTRACT.md §3), assumed to have failed there;
// for impulse_dynamics pass kd = 0 (its restitution's range is the caller's to check). With
// mass_matrix and frame_jacobian: M's failures as diagnose_dynamics, then S = J M⁻¹ Jᵀ + ρI's
// (singular_constraints: a set that lost rank, or a redundant one with ρ = 0, the kernels' pivot
// test); else invalid arguments and inputs only (unclassified).
template <class K>
  requires HasSizes<K> && requires { K::ncontact_sets; K::contact_rows; }
DynamicsDiagnosis diagnose_contact_dynamics(int s, double t, const double* q, const double* qd,
                                            const double* u, const double* p, double kd,
                                            double rho) noexcept {
  constexpr int nv = nv_of<K>;
  DynamicsDiagnosis d;
  d.t = t;
  if (s < 0 || s >= K::ncontact_sets || !(kd >= 0) || !(rho >= 0)) {
    d.failure = std::isnan(kd) || std::isnan(rho) ? DynamicsFailure::non_finite_input
                                                    : DynamicsFailure::invalid_argument;
    return d;
  }
  if (!detail::inputs_finite<K>(t, q, qd, u, p) || !std::isfinite(kd) || !std::isfinite(rho)) {
    d.failure = DynamicsFailure::non_finite_input;
    return d;
  }
  if constexpr (HasMassMatrix<K> && HasFrameJacobian<K> && requires { K::contact_frames; }) {
    std::array<double, nv * nv> M;
    if (!detail::factor_mass_matrix<K>(q, p, M, d)) return d;
    constexpr int most = *std::max_element(K::contact_rows.begin(), K::contact_rows.end());
    const int rows = K::contact_rows[s];
    std::array<double, most * nv> Y{};  // M⁻¹ Jᵀ, column r for row r of J
    std::array<double, most * nv> J{};  // row-major: row r at r * nv
    int r = 0;
    for (int c = K::contact_begin[s]; c < K::contact_begin[s + 1]; ++c) {
      std::array<double, 6 * nv> Jf;
      K::frame_jacobian(K::contact_frames[c], q, p, Jf.data());
      for (int k = 0; k < (K::contact_six_d[c] ? 6 : 3); ++k, ++r)
        for (int j = 0; j < nv; ++j) J[r * nv + j] = Y[j + nv * r] = Jf[k + 6 * j];
    }
    for (int k = 0; k < rows; ++k) linalg::cholesky_solve<double, nv>(M, Y.data() + nv * k);
    std::array<double, most * most> S{};  // J M⁻¹ Jᵀ + ρI, then the identity past the set's rows
    for (int i = 0; i < most; ++i)
      for (int k = 0; k < most; ++k) {
        double x = i == k ? (i < rows ? rho : 1.0) : 0.0;
        if (i < rows && k < rows)
          for (int j = 0; j < nv; ++j) x += J[i * nv + j] * Y[j + nv * k];
        S[i + most * k] = x;
      }
    if (linalg::cholesky_failure<double, most>(S) >= 0) {
      d.failure = DynamicsFailure::singular_constraints;
      return d;
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
