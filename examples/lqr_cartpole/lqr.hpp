// A discrete-time LQR regulator designed from eomgen's dynamics derivatives (the paper's
// "equation of motion sensitivity models"), in plain C++ on fixed-size arrays: no allocation,
// no dependency.
//
//   1. Linearize at an equilibrium (q*, q̇ = 0, u*): with x = (q, q̇),
//        ẋ ≈ A δx + B δu,   A = [0 I; ∂q̈/∂q ∂q̈/∂q̇],   B = [0; ∂q̈/∂u]
//      from the forward_dynamics_derivatives kernel.
//   2. Discretize for a digital controller with sample period h and zero-order hold:
//        [Ad Bd; 0 I] = exp([A B; 0 0] h)   (Taylor series with scaling and squaring).
//   3. Solve the discrete algebraic Riccati equation
//        P = Q + AdᵀP Ad − AdᵀP Bd (R + BdᵀP Bd)⁻¹ BdᵀP Ad
//      by the Riccati recursion (the finite-horizon LQR run backwards until it is stationary;
//      from P = Q it converges monotonically for a stabilizable, detectable pair), and check
//      the answer by its residual.
//   4. u = u* − K (x − x*),   K = (R + BdᵀP Bd)⁻¹ BdᵀP Ad.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <eom/model/kernels.hpp>

namespace examples::lqr {

// A dense R×C matrix, column-major like the kernels' outputs.
template <int R, int C> struct Matrix {
  std::array<double, R * C> a{};
  constexpr double& operator()(int i, int j) noexcept { return a[i + R * j]; }
  constexpr double operator()(int i, int j) const noexcept { return a[i + R * j]; }
  static constexpr Matrix identity() noexcept {
    Matrix m;
    for (int i = 0; i < std::min(R, C); ++i) m(i, i) = 1;
    return m;
  }
};

template <int R, int N, int C>
constexpr Matrix<R, C> operator*(const Matrix<R, N>& x, const Matrix<N, C>& y) noexcept {
  Matrix<R, C> z;
  for (int j = 0; j < C; ++j)
    for (int k = 0; k < N; ++k)
      for (int i = 0; i < R; ++i) z(i, j) += x(i, k) * y(k, j);
  return z;
}
template <int R, int C>
constexpr Matrix<R, C> operator+(Matrix<R, C> x, const Matrix<R, C>& y) noexcept {
  for (int k = 0; k < R * C; ++k) x.a[k] += y.a[k];
  return x;
}
template <int R, int C>
constexpr Matrix<R, C> operator-(Matrix<R, C> x, const Matrix<R, C>& y) noexcept {
  for (int k = 0; k < R * C; ++k) x.a[k] -= y.a[k];
  return x;
}
template <int R, int C> constexpr Matrix<R, C> operator*(double s, Matrix<R, C> x) noexcept {
  for (double& v : x.a) v *= s;
  return x;
}
template <int R, int C> constexpr Matrix<C, R> transpose(const Matrix<R, C>& x) noexcept {
  Matrix<C, R> t;
  for (int j = 0; j < C; ++j)
    for (int i = 0; i < R; ++i) t(j, i) = x(i, j);
  return t;
}
template <int R, int C> double max_abs(const Matrix<R, C>& x) noexcept {
  double m = 0;
  for (double v : x.a) m = std::max(m, std::abs(v));
  return m;
}

// B := A⁻¹ B by Gaussian elimination with partial pivoting; false when A is singular to working
// precision (a pivot below 1e3·ε times the largest entry of A) or not finite.
template <int N, int C> bool solve(Matrix<N, N> A, Matrix<N, C>& B) noexcept {
  const double scale = max_abs(A);
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  for (int k = 0; k < N; ++k) {
    int pivot = k;
    for (int i = k + 1; i < N; ++i)
      if (std::abs(A(i, k)) > std::abs(A(pivot, k))) pivot = i;
    if (!(std::abs(A(pivot, k)) > 1e3 * std::numeric_limits<double>::epsilon() * scale))
      return false;
    for (int j = 0; j < N; ++j) std::swap(A(k, j), A(pivot, j));
    for (int j = 0; j < C; ++j) std::swap(B(k, j), B(pivot, j));
    for (int i = k + 1; i < N; ++i) {
      const double f = A(i, k) / A(k, k);
      for (int j = k; j < N; ++j) A(i, j) -= f * A(k, j);
      for (int j = 0; j < C; ++j) B(i, j) -= f * B(k, j);
    }
  }
  for (int k = N - 1; k >= 0; --k)
    for (int j = 0; j < C; ++j) {
      double s = B(k, j);
      for (int i = k + 1; i < N; ++i) s -= A(k, i) * B(i, j);
      B(k, j) = s / A(k, k);
    }
  return true;
}

// exp(X) by scaling and squaring: X/2^s has norm ≤ 1/2, where the Taylor series converges to
// round-off in at most 20 terms; then s squarings.
template <int N> Matrix<N, N> exponential(Matrix<N, N> X) noexcept {
  int squarings = 0;
  while (max_abs(X) * N > 0.5 && squarings < 64) X = 0.5 * X, ++squarings;  // ‖X‖₁ ≤ N·max|xᵢⱼ|
  Matrix<N, N> sum = Matrix<N, N>::identity(), term = sum;
  for (int k = 1; k <= 30; ++k) {
    term = (1.0 / k) * (term * X);
    sum = sum + term;
    if (max_abs(term) <= std::numeric_limits<double>::epsilon() * max_abs(sum)) break;
  }
  for (int i = 0; i < squarings; ++i) sum = sum * sum;
  return sum;
}

// The spectral radius of A, from ‖A^k‖^(1/k) → ρ(A) with k = 2^48, by squaring with the norm
// divided out at each step (so nothing under- or overflows). Good to many digits unless the
// dominant eigenvalue is defective.
template <int N> double spectral_radius(Matrix<N, N> A) noexcept {
  double log_scale = 0;  // log of the factor divided out of A^(2^i)
  constexpr int squarings = 48;
  for (int i = 0; i < squarings; ++i) {
    const double s = max_abs(A);
    if (!(s > 0)) return 0;  // nilpotent
    A = (1.0 / s) * A;
    log_scale = 2 * (log_scale + std::log(s));
    A = A * A;
  }
  return std::exp((log_scale + std::log(max_abs(A))) / std::ldexp(1.0, squarings));
}

// The model linearized at (q, q̇, u): ẋ ≈ A δx + B δu with x = (q, q̇).
template <int nq, int nu> struct Linearization {
  Matrix<2 * nq, 2 * nq> A;
  Matrix<2 * nq, nu> B;
};

template <class Model> bool linearize(const double* q, const double* qd, const double* u,
                                      const double* p,
                                      Linearization<Model::nq, Model::nu>& lin) noexcept {
  using K = eom::RequireKernels<Model, eom::Kernel::forward_dynamics_derivatives>;
  constexpr int n = K::nq, m = K::nu;
  Matrix<n, n> dq, dqd;
  Matrix<n, m> du;
  if (!K::forward_dynamics_derivatives(0.0, q, qd, u, p, dq.a.data(), dqd.a.data(), du.a.data()))
    return false;
  lin = {};
  for (int i = 0; i < n; ++i) {
    lin.A(i, n + i) = 1;  // d/dt q = q̇
    for (int j = 0; j < n; ++j) lin.A(n + i, j) = dq(i, j), lin.A(n + i, n + j) = dqd(i, j);
    for (int j = 0; j < m; ++j) lin.B(n + i, j) = du(i, j);
  }
  return true;
}

// Zero-order-hold discretization with sample period h: [Ad Bd; 0 I] = exp([A B; 0 0] h).
template <int n, int m> struct Discrete {
  Matrix<n, n> A;
  Matrix<n, m> B;
};
template <int n, int m>
Discrete<n, m> zero_order_hold(const Matrix<n, n>& A, const Matrix<n, m>& B, double h) noexcept {
  Matrix<n + m, n + m> X;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) X(i, j) = A(i, j) * h;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) X(i, n + j) = B(i, j) * h;
  const auto E = exponential(X);
  Discrete<n, m> d;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) d.A(i, j) = E(i, j);
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) d.B(i, j) = E(i, n + j);
  return d;
}

// One step of the Riccati recursion, P ↦ Q + AᵀPA − AᵀPB (R + BᵀPB)⁻¹ BᵀPA, and the gain
// K = (R + BᵀPB)⁻¹ BᵀPA; false when R + BᵀPB is singular.
template <int n, int m> bool riccati_step(const Discrete<n, m>& d, const Matrix<n, n>& Q,
                                          const Matrix<m, m>& R, const Matrix<n, n>& P,
                                          Matrix<n, n>& next, Matrix<m, n>& K) noexcept {
  const Matrix<m, n> BtP = transpose(d.B) * P;
  const Matrix<m, n> BtPA = BtP * d.A;
  K = BtPA;
  if (!solve(R + BtP * d.B, K)) return false;
  next = Q + transpose(d.A) * P * d.A - transpose(BtPA) * K;
  next = 0.5 * (next + transpose(next));  // keep P exactly symmetric
  return true;
}

template <int n, int m> struct Riccati {
  bool converged = false;
  long iterations = 0;
  Matrix<n, n> P;
  Matrix<m, n> K;
  double residual = 0;           // ‖Ric(P) − P‖max / ‖P‖max
  double lyapunov_residual = 0;  // ‖Q + KᵀRK + AclᵀP Acl − P‖max / ‖P‖max, Acl = A − BK
  double spectral_radius = 0;  // of Acl: < 1 is a stable closed loop
};

// The stabilizing solution of the DARE; gives up (converged = false) after max_iterations.
// Stops when an iteration changes P by less than tolerance·‖P‖; the recursion converges
// linearly, by about ρ(Acl)² per iteration.
template <int n, int m>
Riccati<n, m> solve_dare(const Discrete<n, m>& d, const Matrix<n, n>& Q, const Matrix<m, m>& R,
                         long max_iterations = 1'000'000, double tolerance = 1e-14) noexcept {
  Riccati<n, m> r;
  r.P = Q;
  Matrix<n, n> next;
  while (r.iterations < max_iterations) {
    if (!riccati_step(d, Q, R, r.P, next, r.K)) return r;
    ++r.iterations;
    const double change = max_abs(next - r.P);
    r.P = next;
    if (!std::isfinite(change)) return r;
    if (change <= tolerance * max_abs(r.P)) {
      r.converged = true;
      break;
    }
  }
  if (!r.converged || !riccati_step(d, Q, R, r.P, next, r.K)) {
    r.converged = false;
    return r;
  }
  const double size = max_abs(r.P);
  r.residual = max_abs(next - r.P) / size;
  const Matrix<n, n> Acl = d.A - d.B * r.K;
  r.lyapunov_residual =
      max_abs(Q + transpose(r.K) * R * r.K + transpose(Acl) * r.P * Acl - r.P) / size;
  r.spectral_radius = spectral_radius(Acl);
  return r;
}

// The regulator u = u* − K (x − x*), x = (q, q̇); allocation-free and noexcept, for the loop.
template <int nq, int nu> struct Regulator {
  std::array<double, 2 * nq> x_eq{};
  std::array<double, nu> u_eq{};
  Matrix<nu, 2 * nq> K;
  void control(const double* x, double* u) const noexcept {
    for (int i = 0; i < nu; ++i) {
      double s = u_eq[i];
      for (int j = 0; j < 2 * nq; ++j) s -= K(i, j) * (x[j] - x_eq[j]);
      u[i] = s;
    }
  }
};

}  // namespace examples::lqr
