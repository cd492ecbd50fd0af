// The contact kernels' reference (docs/CONTRACT.md §3): a contact set's KKT system
//   [M −Jᵀ; J εI] [x; λ] = [f; −γ]
// built from eom::Reference<Model, Real> (M, c, ∂V/∂q, Q, the frames' Jacobians and biases: the
// runtime AD, nothing generated) and solved by Gaussian elimination with partial pivoting:
// contact dynamics x = v̇, f = Q − c − ∂V/∂q, γ = a + kd J v; the impulse x = v⁺ − v⁻, f = 0,
// γ = (1 + e) J v⁻. ε = 0 but for a redundant set, where a tiny ε picks the least-norm λ.
#pragma once

#include <cmath>
#include <utility>
#include <vector>

namespace eomtest {

struct ContactFrame {
  int frame;  // the Reference's frame index (its frame_names)
  bool six_d;
};

// x solving A x = b (n × n, column-major) by Gaussian elimination with partial pivoting.
template <class Real> std::vector<Real> gauss_solve(std::vector<Real> A, std::vector<Real> b) {
  using std::abs;
  const int n = static_cast<int>(b.size());
  for (int k = 0; k < n; ++k) {
    int pivot = k;
    for (int i = k + 1; i < n; ++i)
      if (abs(A[i + n * k]) > abs(A[pivot + n * k])) pivot = i;
    for (int j = 0; j < n; ++j) std::swap(A[k + n * j], A[pivot + n * j]);
    std::swap(b[k], b[pivot]);
    for (int i = k + 1; i < n; ++i) {
      const Real l = A[i + n * k] / A[k + n * k];
      for (int j = k; j < n; ++j) A[i + n * j] -= l * A[k + n * j];
      b[i] -= l * b[k];
    }
  }
  for (int i = n - 1; i >= 0; --i) {
    for (int j = i + 1; j < n; ++j) b[i] -= A[i + n * j] * b[j];
    b[i] /= A[i + n * i];
  }
  return b;
}

// The set's stacked Jacobian (rows × nv, column-major) and bias.
template <class Real> struct ContactTerms {
  int rows = 0;
  std::vector<Real> J, a;
};
template <class R, class Real>
ContactTerms<Real> contact_terms(const std::vector<ContactFrame>& set, const Real* q, const Real* v, const Real* p) {
  constexpr int nv = R::nv;
  ContactTerms<Real> t;
  for (const ContactFrame& c : set) t.rows += c.six_d ? 6 : 3;
  t.J.assign(t.rows * nv, Real(0.0));
  int at = 0;
  for (const ContactFrame& c : set) {
    std::vector<Real> Jf(6 * nv), af(6);
    R::frame_jacobian(c.frame, q, p, Jf.data());
    R::frame_acceleration_bias(c.frame, q, v, p, af.data());
    for (int r = 0; r < (c.six_d ? 6 : 3); ++r, ++at) {
      for (int j = 0; j < nv; ++j) t.J[at + t.rows * j] = Jf[r + 6 * j];
      t.a.push_back(af[r]);
    }
  }
  return t;
}

// The point's M and f = Q − c − ∂V/∂q (M left empty when mass is false: it does not depend on v
// or u, so differences along them reuse it).
template <class Real> struct DynamicsTerms {
  std::vector<Real> M, f;
};
template <class R, class Real>
DynamicsTerms<Real> dynamics_terms(const Real* q, const Real* v, const Real* u, const Real* p, bool mass = true) {
  constexpr int nv = R::nv;
  DynamicsTerms<Real> d;
  std::vector<Real> c(nv), dV(nv), Q(nv);
  if (mass) {
    d.M.resize(nv * nv);
    R::mass_matrix(q, p, d.M.data());
  }
  R::coriolis(q, v, p, c.data());
  R::potential_gradient(q, p, dV.data());
  R::generalized_forces(Real(0.0), q, v, u, p, Q.data());
  for (int i = 0; i < nv; ++i) d.f.push_back(Q[i] - c[i] - dV[i]);
  return d;
}

template <class Real> struct Kkt {
  int rows = 0;
  std::vector<Real> A, b;
};
// The system from its terms at a point whose velocity (v⁻ for the impulse) is v.
template <class Real>
Kkt<Real> assemble_kkt(const DynamicsTerms<Real>& d, const ContactTerms<Real>& t, const Real* v, double kd, double e,
                       bool impulse, double epsilon) {
  const int nv = static_cast<int>(d.f.size()), n = nv + t.rows;
  Kkt<Real> k{t.rows, std::vector<Real>(n * n, Real(0.0)), std::vector<Real>(n, Real(0.0))};
  for (int i = 0; i < nv; ++i)
    for (int j = 0; j < nv; ++j) k.A[i + n * j] = d.M[i + nv * j];
  for (int r = 0; r < t.rows; ++r) {
    Real Jv = 0.0;
    for (int j = 0; j < nv; ++j) {
      k.A[nv + r + n * j] = t.J[r + t.rows * j];
      k.A[j + n * (nv + r)] = -t.J[r + t.rows * j];
      Jv += t.J[r + t.rows * j] * v[j];
    }
    k.A[nv + r + n * (nv + r)] = epsilon;
    k.b[nv + r] = impulse ? -(1.0 + Real(e)) * Jv : -(t.a[r] + kd * Jv);
  }
  if (!impulse)
    for (int i = 0; i < nv; ++i) k.b[i] = d.f[i];
  return k;
}
template <class R, class Real>
Kkt<Real> contact_kkt(const std::vector<ContactFrame>& set, const Real* q, const Real* v, const Real* u,
                      const Real* p, double kd, double e, bool impulse, double epsilon) {
  return assemble_kkt(dynamics_terms<R>(q, v, u, p), contact_terms<R>(set, q, v, p), v, kd, e, impulse, epsilon);
}

}  // namespace eomtest
