// Forward dynamics of eom::models::UndampedChain<N> derived by hand: the
// baseline the generated forward_dynamics is measured against (bench/bench_hand_chain.cpp) and
// checked against (tests/hand_chain).
//
// Coordinates as in models/chain.hpp: θᵢ is link i's absolute angle from the horizontal (link i
// spans lᵢ (cᵢ, sᵢ), cᵢ = cos θᵢ, sᵢ = sin θᵢ), from joint i to joint i+1, its mass centre at its
// middle; gravity along −y.
// Parameters as chain_detail::Names<N>: p = (m₁..m_N, l₁..l_N, I₁..I_N, c₁..c_N, g); the c's are
// the damped chain's and unused here. With eⱼ = (−sⱼ, cⱼ), the velocity of mass centre i is
// Σ_{j<i} lⱼ θ̇ⱼ eⱼ + ½ lᵢ θ̇ᵢ eᵢ and eⱼ·e_k = cos(θⱼ − θ_k), so T = ½ Σ a_jk cos(θⱼ − θ_k) θ̇ⱼ θ̇_k
// with (0-based, S_i = Σ_{r≥i} m_r the mass from link i to the tip, S_N = 0)
//     b_k  = l_k (½ m_k + S_{k+1})    (the mass at and below link k, seen at l_k)
//     a_jk = l_j b_k                  for j < k (symmetric)
//     a_jj = l_j² (¼ m_j + S_{j+1}) + I_j
// and V = g Σ mᵢ yᵢ gives ∂V/∂θⱼ = g bⱼ cⱼ. Lagrange's equations:
//     Σ_k a_jk cos(θⱼ − θ_k) θ̈_k + Σ_k a_jk sin(θⱼ − θ_k) θ̇_k² + g bⱼ cⱼ = 0,
// the textbook chain: N sin/cos, cos and sin of the differences by the angle-difference identity,
// then M q̈ = f by LDLᵀ (no square roots) with reciprocal pivots. No input or pivot checks: M of a
// chain with positive masses and inertias is positive definite.
#pragma once

#include <array>
#include <cmath>

namespace hand_chain {

// The parameter-only products, computed once per parameter set: a_jk (j ≤ k, packed by rows of
// the upper triangle) and −g bⱼ.
template <int N, class S = double> struct Coefficients {
  std::array<S, N * (N + 1) / 2> a;
  std::array<S, N> minus_gb;
};

template <int N, class S = double> void prepare(const S* p, Coefficients<N, S>& k) {
  const S* m = p;
  const S* l = p + N;
  const S* I = p + 2 * N;
  const S& g = p[4 * N];
  std::array<S, N> b;
  S below(0);  // S_{i+1}
  for (int i = N - 1; i >= 0; --i) {
    b[i] = l[i] * (S(0.5) * m[i] + below);
    k.minus_gb[i] = -(g * b[i]);
    const S diagonal = l[i] * l[i] * (S(0.25) * m[i] + below) + I[i];
    below = below + m[i];
    // Row i of the upper triangle starts at i·N − i(i−1)/2; its first entry is the diagonal.
    S* row = k.a.data() + i * N - i * (i - 1) / 2;
    row[0] = diagonal;
    for (int j = i + 1; j < N; ++j) row[j - i] = l[i] * b[j];
  }
}

// q̈ from prepared coefficients. L (lower triangle, row-major N×N) holds M and then, in place,
// the unit lower factor of M = L D Lᵀ; only 1/D is kept.
template <int N, class S = double>
void forward_dynamics(const S* q, const S* qd, const Coefficients<N, S>& k, S* qdd) {
  using std::cos, std::sin;
  std::array<S, N> c, s, w, f, d, inverse_d, t;
  std::array<S, N * N> L;
  for (int i = 0; i < N; ++i) {
    c[i] = cos(q[i]);
    s[i] = sin(q[i]);
    w[i] = qd[i] * qd[i];
    f[i] = k.minus_gb[i] * c[i];  // −∂V/∂θᵢ
  }
  // M and f = −c(q, q̇) − ∂V/∂q: each pair j < k once (sin(θ_k − θⱼ) = −sin(θⱼ − θ_k)).
  for (int j = 0; j < N; ++j) {
    const S* a = k.a.data() + j * N - j * (j - 1) / 2 - j;  // a[k] = a_jk for k ≥ j
    L[j * N + j] = a[j];
    for (int i = j + 1; i < N; ++i) {
      const S cos_ji = c[j] * c[i] + s[j] * s[i];
      const S sin_ji = s[j] * c[i] - c[j] * s[i];
      L[i * N + j] = a[i] * cos_ji;
      const S x = a[i] * sin_ji;
      f[j] = f[j] - x * w[i];
      f[i] = f[i] + x * w[j];
    }
  }
  // LDLᵀ by rows: t_k = L_jk d_k, d_j = M_jj − Σ t_k L_jk, L_ij = (M_ij − Σ L_ik t_k) / d_j.
  for (int j = 0; j < N; ++j) {
    d[j] = L[j * N + j];
    for (int r = 0; r < j; ++r) {
      t[r] = L[j * N + r] * d[r];
      d[j] = d[j] - t[r] * L[j * N + r];
    }
    inverse_d[j] = S(1) / d[j];
    for (int i = j + 1; i < N; ++i) {
      S x = L[i * N + j];
      for (int r = 0; r < j; ++r) x = x - L[i * N + r] * t[r];
      L[i * N + j] = x * inverse_d[j];
    }
  }
  // L y = f, then Lᵀ q̈ = D⁻¹ y (column sweep: rows of L are contiguous).
  for (int i = 0; i < N; ++i)
    for (int r = 0; r < i; ++r) f[i] = f[i] - L[i * N + r] * f[r];
  for (int i = 0; i < N; ++i) qdd[i] = f[i] * inverse_d[i];
  for (int r = N - 1; r > 0; --r)
    for (int i = 0; i < r; ++i) qdd[i] = qdd[i] - L[r * N + i] * qdd[r];
}

// The same q̈ with the factorization a tuned hand-written code would use: LDLᵀ in place,
// right-looking, so that every update is a multiply-add along a contiguous row of L (an axpy,
// which the compiler vectorizes as written; a dot product would need its sum reassociated), the
// sizes constants. L y = f rides along the factorization, Lᵀ q̈ = D⁻¹ y runs along rows too. This
// is the floor at large N: the LDLᵀ above forms inner products whose single running sums wait on
// each other (a dot-product Cholesky with four partial sums was slower still at N = 50: each
// row's entries wait on the previous ones).
template <int N, class S = double>
void forward_dynamics_rows(const S* q, const S* qd, const Coefficients<N, S>& k, S* qdd) {
  using std::cos, std::sin;
  std::array<S, N> c, s, w, f, column;
  std::array<S, N * N> L;
  for (int i = 0; i < N; ++i) {
    c[i] = cos(q[i]);
    s[i] = sin(q[i]);
    w[i] = qd[i] * qd[i];
    f[i] = k.minus_gb[i] * c[i];
  }
  for (int j = 0; j < N; ++j) {  // M and f as forward_dynamics builds them
    const S* a = k.a.data() + j * N - j * (j - 1) / 2 - j;
    L[j * N + j] = a[j];
    for (int i = j + 1; i < N; ++i) {
      const S cos_ji = c[j] * c[i] + s[j] * s[i];
      const S sin_ji = s[j] * c[i] - c[j] * s[i];
      L[i * N + j] = a[i] * cos_ji;
      const S x = a[i] * sin_ji;
      f[j] = f[j] - x * w[i];
      f[i] = f[i] + x * w[j];
    }
  }
  for (int j = 0; j < N; ++j) {
    const S inverse_d = S(1) / L[j * N + j];
    qdd[j] = inverse_d;  // D⁻¹, kept for the back substitution
    for (int i = j + 1; i < N; ++i) {
      column[i] = L[i * N + j];  // M's column below the pivot, before it is scaled
      L[i * N + j] = column[i] * inverse_d;
      f[i] = f[i] - L[i * N + j] * f[j];
    }
    for (int i = j + 1; i < N; ++i) {  // rows below: M(i, j+1..i) −= L(i, j) D(j) L(j+1..i, j)
      S* li = L.data() + i * N;
      const S lij = li[j];
      for (int m = j + 1; m <= i; ++m) li[m] = li[m] - lij * column[m];
    }
  }
  for (int i = 0; i < N; ++i) qdd[i] = f[i] * qdd[i];
  for (int r = N - 1; r > 0; --r)
    for (int i = 0; i < r; ++i) qdd[i] = qdd[i] - L[r * N + i] * qdd[r];
}

// Everything per call, the parameter-only products included.
template <int N, class S = double>
void forward_dynamics(const S* q, const S* qd, const S* p, S* qdd) {
  Coefficients<N, S> k;
  prepare<N, S>(p, k);
  forward_dynamics<N, S>(q, qd, k, qdd);
}

}  // namespace hand_chain

namespace hand_chain {

// Operation counting: a double that counts every +, −, ×, ÷, negation, sin and cos done on it,
// so the count stated for the hand-derived code is the code's, not an estimate.
struct Counted {
  double v = 0;
  static inline long operations = 0;
  Counted() = default;
  Counted(double x) : v(x) {}  // NOLINT: constants enter the code as doubles, uncounted
  friend Counted operator+(Counted a, Counted b) { return ++operations, Counted(a.v + b.v); }
  friend Counted operator-(Counted a, Counted b) { return ++operations, Counted(a.v - b.v); }
  friend Counted operator*(Counted a, Counted b) { return ++operations, Counted(a.v * b.v); }
  friend Counted operator/(Counted a, Counted b) { return ++operations, Counted(a.v / b.v); }
  friend Counted operator-(Counted a) { return ++operations, Counted(-a.v); }
  friend Counted sin(Counted a) { return ++operations, Counted(std::sin(a.v)); }
  friend Counted cos(Counted a) { return ++operations, Counted(std::cos(a.v)); }
};

// The counts as formulas (2N of them sin and cos; the test checks them against Counted):
//   per call, from prepared coefficients:  6N + 19 N(N−1)/2 + N(N−1)(2N−1)/6
//     (2N sin/cos; 2N for θ̇² and the gravity terms; 12 per pair j < k for M and f; the LDLᵀ
//      N(N−1)(2N−1)/6 + 3N(N−1)/2 + N, ≈ N³/6 multiply-adds; the solves 2N(N−1) + N)
//   prepare (the parameter-only products):  11N + N(N−1)/2
constexpr long operations_prepared(long n) {
  return 6 * n + 19 * n * (n - 1) / 2 + n * (n - 1) * (2 * n - 1) / 6;
}
constexpr long operations_prepare(long n) { return 11 * n + n * (n - 1) / 2; }

// The counts by running the code on Counted.
template <int N> long counted_operations(bool with_prepare) {
  std::array<Counted, 4 * N + 1> p;
  std::array<Counted, N> q, qd, qdd;
  for (int i = 0; i < 4 * N + 1; ++i) p[i] = 1.0;
  for (int i = 0; i < N; ++i) q[i] = 0.1 * i, qd[i] = 0.2;
  Coefficients<N, Counted> k;
  Counted::operations = 0;
  if (with_prepare)
    forward_dynamics<N, Counted>(q.data(), qd.data(), p.data(), qdd.data());
  else {
    prepare<N, Counted>(p.data(), k);
    Counted::operations = 0;
    forward_dynamics<N, Counted>(q.data(), qd.data(), k, qdd.data());
  }
  return Counted::operations;
}

}  // namespace hand_chain
