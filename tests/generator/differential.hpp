// The differential test of the derived graphs: for random Lagrangians, every kernel built by the
// generator (evaluated in-process by eom::gen::evaluate) against eom::Reference<Model> and
// against central finite differences.
//
// Norms: for a kernel output x and its reference r, error = max|x − r| / max(1, max|r|), which
// must be ≤ 1e-12 (round-off of both evaluation orders). Finite differences are checked with the
// same norm at tolerances matched to their truncation and cancellation errors (below).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <optional>
#include <string>
#include <vector>

#include <eom/reference/reference.hpp>
#include <eomgen/trace.hpp>
#include <eomgen/taylor.hpp>

#include "random_model.hpp"

namespace eomtest {

using eom::gen::KernelId;
using Vec = std::vector<double>;

inline double relative_error(const Vec& x, const Vec& r) {
  double diff = 0, scale = 1;
  for (std::size_t i = 0; i < r.size(); ++i) {
    diff = std::max(diff, std::abs(x.at(i) - r[i]));
    scale = std::max(scale, std::abs(r[i]));
  }
  return (x.size() == r.size() && std::isfinite(diff)) ? diff / scale : INFINITY;
}

// The worst error seen per check, and the operations the traced graphs contained.
struct Worst {
  std::map<std::string, double> error;
  std::set<eom::gen::Op> ops;
  int cases = 0;
  void record(const std::string& what, double e) { error[what] = std::max(error[what], e); }
  void print() const {
    std::printf("worst errors over %d random Lagrangians (max-abs / max(1, max-abs reference)):\n",
                cases);
    for (const auto& [what, e] : error) std::printf("  %-44s %.3g\n", what.c_str(), e);
  }
};
inline Worst& worst() {
  static Worst w;
  return w;
}

inline constexpr double reference_tolerance = 1e-12;

template <class Model> void run_case(unsigned seed);

// Runs `cases` random models of one shape, then prints the worst errors and checks that the
// traced graphs used every real operation of the tape.
template <class Model> void run_shape(unsigned first_seed, unsigned cases) {
  worst() = Worst{};
  for (unsigned s = 0; s < cases; ++s) {
    run_case<Model>(first_seed + s);
    if (::testing::Test::HasFatalFailure()) return;
  }
  worst().print();
  using eom::gen::Op;
  for (Op op : {Op::Neg, Op::Add, Op::Sub, Op::Mul, Op::Div, Op::Sin, Op::Cos, Op::Tan, Op::Tanh,
                Op::Asin, Op::Acos, Op::Atan, Op::Exp, Op::Log, Op::Sqrt, Op::Abs, Op::Pow, Op::Atan2,
                Op::Hypot, Op::Select, Op::Less})
    EXPECT_TRUE(worst().ops.count(op)) << "no " << eom::gen::name(op) << " in any traced model";
}

template <class Model>
void run_case(unsigned seed) {
  using Info = eom::ModelInfo<Model>;
  using Ref = eom::Reference<Model>;
  constexpr int nq = Info::nq, nc = Info::nc, nu = Info::nu;
  Model::L = random_lagrangian(seed, nq, nc, nu, Info::has_generalized_forces);
  SCOPED_TRACE("seed " + std::to_string(seed) + ", nq " + std::to_string(nq) + ", nc " +
               std::to_string(nc) + ", nu " + std::to_string(nu));

  // Odd seeds fix parameter b (at its default) as FIXED_PARAMETERS would.
  const bool fix_b = seed % 2 == 1;
  std::vector<std::optional<double>> fixed(3);
  if (fix_b) fixed[1] = 1.1;
  eom::gen::TracedModel m = eom::gen::trace<Model>("random", "RandomModel", fixed);
  const std::vector<eom::gen::Kernel> kernels =
      eom::gen::build_kernels(m, eom::gen::applicable_kernels(m));
  ASSERT_EQ(m.np(), fix_b ? 2 : 3);
  ++worst().cases;
  for (eom::gen::NodeId n = 0; n < m.graph.size(); ++n) worst().ops.insert(m.graph[n].op);

  TreeMaker rng(seed * 7919u + 17u);
  for (int trial = 0; trial < 2; ++trial) {
    eom::gen::Point x;
    const Vec p_all{0.8, 1.1, 0.6};
    x.p = fix_b ? Vec{0.8, 0.6} : p_all;
    for (int i = 0; i < nq; ++i) {
      x.q.push_back(rng.uniform(-1, 1));
      x.qd.push_back(rng.uniform(-1, 1));
      x.qdd.push_back(rng.uniform(-1, 1));
    }
    for (int i = 0; i < nu; ++i) x.u.push_back(rng.uniform(-1, 1));
    x.t = rng.uniform(0, 1);
    const double* P = p_all.data();
    const double* U = nu ? x.u.data() : nullptr;

    auto kernel = [&](KernelId id) -> const eom::gen::Kernel& {
      for (const auto& k : kernels)
        if (k.id == id) return k;
      throw std::logic_error("kernel not built");
    };
    // A kernel's outputs at point y, with its guards checked.
    auto eval = [&](KernelId id, const eom::gen::Point& y) {
      const auto& k = kernel(id);
      for (double g : eom::gen::evaluate(m.graph, k.guards, y)) EXPECT_EQ(g, 1.0);
      return eom::gen::evaluate(m.graph, k.outputs, y);
    };
    auto check = [&](KernelId id, const Vec& ref) {
      const std::string name(eom::gen::signature(id).name);
      const double e = relative_error(eval(id, x), ref);
      worst().record(name + " vs Reference", e);
      EXPECT_LE(e, reference_tolerance) << name;
    };
    auto check_fd = [&](const std::string& what, const Vec& got, const Vec& fd, double tol) {
      const double e = relative_error(got, fd);
      worst().record(what + " vs finite differences", e);
      EXPECT_LE(e, tol) << what;
    };

    // ---- against the reference ----
    Vec M(nq * nq), Mdot(nq * nq), c(nq), dV(nq), Q(nq), qdd(nq), tau(nq);
    Ref::mass_matrix(x.q.data(), P, M.data());
    check(KernelId::mass_matrix, M);
    Ref::mass_matrix_dot(x.q.data(), x.qd.data(), P, Mdot.data());
    check(KernelId::mass_matrix_dot, Mdot);
    Ref::coriolis(x.q.data(), x.qd.data(), P, c.data());
    check(KernelId::coriolis, c);
    Ref::potential_gradient(x.q.data(), P, dV.data());
    check(KernelId::potential_gradient, dV);
    Ref::generalized_forces(x.t, x.q.data(), x.qd.data(), U, P, Q.data());
    check(KernelId::generalized_forces, Q);
    check(KernelId::kinetic_energy, {Ref::kinetic_energy(x.q.data(), x.qd.data(), P)});
    check(KernelId::potential_energy, {Ref::potential_energy(x.q.data(), P)});
    ASSERT_TRUE(Ref::forward_dynamics(x.t, x.q.data(), x.qd.data(), U, P, qdd.data()));
    check(KernelId::forward_dynamics, qdd);
    Vec dq(nq * nq), dqd(nq * nq), du(nq * nu + 1);
    ASSERT_TRUE(Ref::forward_dynamics_derivatives(x.t, x.q.data(), x.qd.data(), U, P, dq.data(),
                                                  dqd.data(), du.data()));
    Vec dall = dq;
    dall.insert(dall.end(), dqd.begin(), dqd.end());
    dall.insert(dall.end(), du.begin(), du.begin() + nq * nu);
    check(KernelId::forward_dynamics_derivatives, dall);
    Ref::inverse_dynamics(x.t, x.q.data(), x.qd.data(), x.qdd.data(), U, P, tau.data());
    check(KernelId::inverse_dynamics, tau);
    {  // Taylor mode: the generator's recurrences (what taylor_coefficients runs) against the
       // reference's Taylor arithmetic, per order k in the norm above; coefficient k sums ~k
       // products of lower ones, so round-off grows about linearly: bound 1e-12 (1 + k).
      constexpr int order = 8;
      const auto series =
          eom::gen::taylor_ode(m.graph, *kernel(KernelId::taylor_coefficients).system, x, order);
      Vec qk(nq * (order + 1)), qdk(nq * (order + 1));
      ASSERT_TRUE(Ref::taylor_coefficients(order, x.t, x.q.data(), x.qd.data(), U, P, qk.data(),
                                           qdk.data(), nullptr));
      for (int k = 0; k <= order; ++k) {
        auto slice = [&](const Vec& v) { return Vec(v.begin() + k * nq, v.begin() + (k + 1) * nq); };
        const double e = std::max(relative_error(slice(series[0]), slice(qk)),
                                  relative_error(slice(series[1]), slice(qdk)));
        worst().record("taylor_coefficients vs Reference, / (1 + k)", e / (1 + k));
        EXPECT_LE(e, reference_tolerance * (1 + k)) << "taylor_coefficients, order " << k;
      }
    }
    Vec C(nc * nq), gamma(nc);
    if constexpr (nc > 0) {
      Vec phi(nc);
      Ref::constraint_residual(x.q.data(), P, phi.data());
      check(KernelId::constraint_residual, phi);
      Ref::constraint_jacobian(x.q.data(), P, C.data());
      check(KernelId::constraint_jacobian, C);
      Ref::constraint_bias(x.q.data(), x.qd.data(), P, gamma.data());
      check(KernelId::constraint_bias, gamma);
    }

    // ---- against finite differences (of the model in double, or of other derived kernels) ----
    const Vec Mg = eval(KernelId::mass_matrix, x);
    {  // T is quadratic in q̇, so a second difference with a large step is exact up to round-off
      const double h = 0.5;
      Vec fd(nq * nq);
      for (int i = 0; i < nq; ++i)
        for (int j = 0; j < nq; ++j) {
          auto T = [&](double si, double sj) {
            Vec v = x.qd;
            v[i] += si * h;
            v[j] += sj * h;
            return Model::template kinetic_energy<double>(x.q, v, p_all);
          };
          fd[i + nq * j] = (T(1, 1) - T(1, -1) - T(-1, 1) + T(-1, -1)) / (4 * h * h);
        }
      check_fd("mass_matrix", Mg, fd, 1e-12);
    }
    const double h = 1e-6;
    auto shifted = [&](auto&& change) {
      eom::gen::Point y = x;
      change(y);
      return y;
    };
    {  // Ṁ: (M(q + h q̇) − M(q − h q̇)) / 2h
      const auto Mp = eval(KernelId::mass_matrix, shifted([&](auto& y) { for (int i = 0; i < nq; ++i) y.q[i] += h * x.qd[i]; }));
      const auto Mm = eval(KernelId::mass_matrix, shifted([&](auto& y) { for (int i = 0; i < nq; ++i) y.q[i] -= h * x.qd[i]; }));
      Vec fd(nq * nq);
      for (int k = 0; k < nq * nq; ++k) fd[k] = (Mp[k] - Mm[k]) / (2 * h);
      check_fd("mass_matrix_dot", eval(KernelId::mass_matrix_dot, x), fd, 1e-7);
      // c = Ṁq̇ − ∂T/∂q
      const Vec Md = eval(KernelId::mass_matrix_dot, x);
      Vec cfd(nq);
      for (int i = 0; i < nq; ++i) {
        Vec a = x.q, b = x.q;
        a[i] += h;
        b[i] -= h;
        double s = -(Model::template kinetic_energy<double>(a, x.qd, p_all) -
                     Model::template kinetic_energy<double>(b, x.qd, p_all)) / (2 * h);
        for (int j = 0; j < nq; ++j) s += Md[i + nq * j] * x.qd[j];
        cfd[i] = s;
      }
      check_fd("coriolis", eval(KernelId::coriolis, x), cfd, 1e-7);
    }
    {  // ∂V/∂q
      Vec fd(nq);
      for (int i = 0; i < nq; ++i) {
        Vec a = x.q, b = x.q;
        a[i] += h;
        b[i] -= h;
        fd[i] = (Model::template potential_energy<double>(a, p_all) -
                 Model::template potential_energy<double>(b, p_all)) / (2 * h);
      }
      check_fd("potential_gradient", eval(KernelId::potential_gradient, x), fd, 1e-7);
    }
    if constexpr (nc > 0) {
      auto phi = [&](const Vec& q) {
        Vec r(nc);
        Model::template constraints<double>(q, p_all, r);
        return r;
      };
      Vec fd(nc * nq), g(nc);
      for (int j = 0; j < nq; ++j) {
        Vec a = x.q, b = x.q;
        a[j] += h;
        b[j] -= h;
        const Vec pa = phi(a), pb = phi(b);
        for (int i = 0; i < nc; ++i) fd[i + nc * j] = (pa[i] - pb[i]) / (2 * h);
      }
      check_fd("constraint_jacobian", eval(KernelId::constraint_jacobian, x), fd, 1e-7);
      // γ = d²/ds² φ(q + s q̇) at s = 0
      const double h2 = 1e-4;
      Vec a = x.q, b = x.q;
      for (int j = 0; j < nq; ++j) {
        a[j] += h2 * x.qd[j];
        b[j] -= h2 * x.qd[j];
      }
      const Vec pa = phi(a), p0 = phi(x.q), pb = phi(b);
      for (int i = 0; i < nc; ++i) g[i] = (pa[i] - 2 * p0[i] + pb[i]) / (h2 * h2);
      check_fd("constraint_bias", eval(KernelId::constraint_bias, x), g, 1e-5);
    }
    {  // ∂q̈/∂(q, q̇, u) against differences of the derived forward dynamics
      Vec fd;
      auto column = [&](std::vector<double> eom::gen::Point::*field, int j) {
        const auto a = eval(KernelId::forward_dynamics, shifted([&](auto& y) { (y.*field)[j] += h; }));
        const auto b = eval(KernelId::forward_dynamics, shifted([&](auto& y) { (y.*field)[j] -= h; }));
        for (int i = 0; i < nq; ++i) fd.push_back((a[i] - b[i]) / (2 * h));
      };
      for (int j = 0; j < nq; ++j) column(&eom::gen::Point::q, j);
      for (int j = 0; j < nq; ++j) column(&eom::gen::Point::qd, j);
      for (int j = 0; j < nu; ++j) column(&eom::gen::Point::u, j);
      check_fd("forward_dynamics_derivatives", eval(KernelId::forward_dynamics_derivatives, x), fd,
               1e-6);
    }
    {  // physics: M symmetric; for nc = 0, τ(q̈ of the forward dynamics) = 0
      for (int i = 0; i < nq; ++i)
        for (int j = 0; j < nq; ++j) EXPECT_EQ(Mg[i + nq * j], Mg[j + nq * i]);
      if constexpr (nc == 0) {
        const eom::gen::Point y = shifted([&](auto& z) { z.qdd = eval(KernelId::forward_dynamics, x); });
        const Vec r = eval(KernelId::inverse_dynamics, y);
        const double e = relative_error(r, Vec(nq, 0.0));
        worst().record("inverse_dynamics(forward_dynamics) = 0", e);
        EXPECT_LE(e, 1e-11);
      }
    }
  }
}

}  // namespace eomtest
