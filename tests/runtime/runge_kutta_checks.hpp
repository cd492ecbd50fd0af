// What the tests of the explicit Runge–Kutta pairs (test_dopri5, test_dop853) share:
//  - the order conditions by rooted trees (Butcher; HNW I §II.2): weights w have order p on the
//    matrix a when Σᵢ wᵢ Φᵢ(τ) = 1/γ(τ) for every rooted tree τ with |τ| ≤ p, where
//    Φᵢ(τ) = Π over the subtrees σ of τ's root of Σⱼ aᵢⱼ Φⱼ(σ); for a continuous extension
//    evaluated at θ the right side is θ^|τ|/γ(τ);
//  - a fixed-step driver over a method's step struct, for measured orders;
//  - the spring pendulum's reference trajectory in double-double (eom/integration/high_precision.hpp).
#pragma once

#include <qd/dd_real.h>

#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include <eom/integration/high_precision.hpp>
#include <eom/reference/reference.hpp>

#include <models/spring_pendulum.hpp>

namespace rk_checks {

using Real = long double;  // the conditions are evaluated in extended precision
using Vector = std::vector<Real>;
using Matrix = std::vector<Vector>;

struct Tree {
  int order;
  Real gamma;                 // the density γ(τ) = |τ| · Π γ(σ) over the subtrees σ
  std::vector<int> subtrees;  // indices into the tree list
};

// Every rooted tree with up to max_order vertices exactly once (a tree is its root's multiset of
// subtrees, listed as non-decreasing indices), subtrees before the trees that contain them.
inline std::vector<Tree> rooted_trees(int max_order) {
  std::vector<Tree> trees{{1, 1, {}}};
  for (int n = 2; n <= max_order; ++n) {
    const int smaller = static_cast<int>(trees.size());  // all trees of order < n
    std::vector<int> pick;
    auto extend = [&](auto& self, int remaining, int from) -> void {
      if (remaining == 0) {
        Tree t{n, static_cast<Real>(n), pick};
        for (int s : pick) t.gamma *= trees[s].gamma;
        trees.push_back(t);
        return;
      }
      for (int s = from; s < smaller; ++s)
        if (trees[s].order <= remaining) {
          pick.push_back(s);
          self(self, remaining - trees[s].order, s);
          pick.pop_back();
        }
    };
    extend(extend, n - 1, 0);
  }
  return trees;
}

template <std::size_t S>
Matrix to_matrix(const std::array<std::array<double, S>, S>& a, bool absolute = false) {
  Matrix out(S, Vector(S));
  for (std::size_t i = 0; i < S; ++i)
    for (std::size_t j = 0; j < S; ++j) out[i][j] = absolute ? std::abs(a[i][j]) : a[i][j];
  return out;
}

template <std::size_t n> Vector to_vector(const std::array<double, n>& w, std::size_t size) {
  Vector out(size, 0);
  for (std::size_t i = 0; i < n && i < size; ++i) out[i] = w[i];
  return out;
}

inline Vector absolute(Vector v) {
  for (Real& x : v) x = std::abs(x);
  return v;
}

// Φ(τ) for every tree τ, a vector over the stages.
inline std::vector<Vector> elementary_weights(const std::vector<Tree>& trees, const Matrix& a) {
  const std::size_t S = a.size();
  std::vector<Vector> phi;
  for (const Tree& t : trees) {
    Vector v(S, 1);
    for (int s : t.subtrees)
      for (std::size_t i = 0; i < S; ++i) {
        Real sum = 0;
        for (std::size_t j = 0; j < S; ++j) sum += a[i][j] * phi[s][j];
        v[i] *= sum;
      }
    phi.push_back(v);
  }
  return phi;
}

// The order conditions of one set of weights on one tableau, with the bound that rounding the
// coefficients to double allows: each term of Σ wᵢΦᵢ(τ) is a product of at most |τ| + 1 ≤ 10
// rounded coefficients (each off by ≤ ε/2), so the sum moves by ≤ 5ε·Σ|wᵢ||Φ|ᵢ(τ), |Φ| being
// Φ over |a|; 16ε leaves room for the long-double arithmetic.
class Conditions {
 public:
  Conditions(const std::vector<Tree>& trees, const Matrix& a, const Matrix& a_abs)
      : trees_(trees), phi_(elementary_weights(trees, a)), phi_abs_(elementary_weights(trees, a_abs)) {}

  // max over trees of order in [lo, hi] of |Σ wᵢΦᵢ(τ) − θ^|τ|/γ(τ)| / bound(τ).
  Real worst_relative(const Vector& w, const Vector& w_abs, int lo, int hi, Real theta = 1) const {
    Real worst = 0;
    for (std::size_t t = 0; t < trees_.size(); ++t) {
      if (trees_[t].order < lo || trees_[t].order > hi) continue;
      Real bound = 0;
      for (std::size_t i = 0; i < w.size(); ++i) bound += w_abs[i] * phi_abs_[t][i];
      bound *= 16 * std::numeric_limits<double>::epsilon();
      worst = std::max(worst, residual(t, w, theta) / bound);
    }
    return worst;
  }
  // max over trees of order in [lo, hi] of |Σ wᵢΦᵢ(τ) − θ^|τ|/γ(τ)|.
  Real worst_residual(const Vector& w, int lo, int hi, Real theta = 1) const {
    Real worst = 0;
    for (std::size_t t = 0; t < trees_.size(); ++t)
      if (trees_[t].order >= lo && trees_[t].order <= hi) worst = std::max(worst, residual(t, w, theta));
    return worst;
  }

 private:
  Real residual(std::size_t t, const Vector& w, Real theta) const {
    Real sum = 0;
    for (std::size_t i = 0; i < w.size(); ++i) sum += w[i] * phi_[t][i];
    return std::abs(sum - std::pow(theta, trees_[t].order) / trees_[t].gamma);
  }
  const std::vector<Tree>& trees_;
  std::vector<Vector> phi_, phi_abs_;
};

// Integrates x' = f(t, x) from t0 to t1 in `steps` equal steps of a method's step struct
// (attempt from k[0] = f(t, x), result in x_new); false when f fails.
template <class Step, std::size_t m, class F>
bool fixed_steps(F&& f, double t0, double t1, long steps, std::array<double, m>& x) {
  Step s;
  const double h = (t1 - t0) / static_cast<double>(steps);
  for (long i = 0; i < steps; ++i) {
    const double t = t0 + static_cast<double>(i) * h;
    if (!f(t, x, s.k[0]) || !std::isfinite(s.attempt(f, t, h, x, eom::AdaptiveOptions{}))) return false;
    x = s.x_new;
  }
  return true;
}

// The spring pendulum from (0.55, 0, 0.01, 2.5) at t = 0, at the given ascending times > 0, from
// Gragg–Bulirsch–Stoer extrapolation in double-double at tolerance 1e-28 (rounded to double:
// exact to the last bit, for practical purposes).
inline std::vector<std::array<double, 4>> spring_pendulum_reference(std::span<const double> times) {
  using SP = eom::models::SpringPendulum;
  std::array<dd_real, 4> x0{dd_real(0.55), dd_real(0.0), dd_real(0.01), dd_real(2.5)};
  std::array<dd_real, 4> p;
  for (int i = 0; i < 4; ++i) p[i] = dd_real(SP::parameter_values[i]);
  std::vector<std::array<double, 4>> out;
  const auto r = eom::extrapolate<SP, dd_real>(0.0, x0, times, nullptr, p.data(), eom::ExtrapolationOptions{},
                                               [&](double, const std::array<dd_real, 4>& x) {
                                                 std::array<double, 4> v;
                                                 for (int i = 0; i < 4; ++i) v[i] = to_double(x[i]);
                                                 out.push_back(v);
                                               });
  if (r.status != eom::Status::ok) out.clear();
  return out;
}

inline double max_abs_difference(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  double d = 0;
  for (int i = 0; i < 4; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

}  // namespace rk_checks
