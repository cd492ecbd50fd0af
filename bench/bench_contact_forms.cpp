// The contact derivative kernels in their two forms (eomgen/kernels.hpp, contact_solve_form),
// paired in one binary (eombench::compare): by rows, the right-hand sides of all directions solved
// at once, each step vectorized across them (the default from contact_rows_from directions),
// against the straight-line form, each direction's solve written out (--solve unrolled). MuJoCo's
// humanoid (27 dof; two flat feet, one) and Solo12 (18; four point feet, a trot pair), every
// parameter folded, kd = 5, restitution 0.5, rho = 0, on a pool of 64 random states. Before timing,
// the two forms' outputs are compared (max-abs difference over max(1, max-abs)).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <eom/model/free_joint.hpp>
#include <forms_humanoid.hpp>
#include <forms_humanoid_unrolled.hpp>
#include <forms_solo12.hpp>
#include <forms_solo12_unrolled.hpp>

#include "paired_timing.hpp"

namespace {

struct State {
  std::vector<double> q, v, u;
};

template <class K> std::vector<State> states(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  std::vector<State> pool(64);
  for (State& s : pool) {
    s.q.resize(K::nq);
    s.v.resize(K::nv);
    s.u.resize(K::nu);
    for (double& x : s.q) x = d(rng);
    if constexpr (K::nq != K::nv)
      eom::normalize_configuration(eom::Layout(K::nq, K::nv, K::quaternions.data()), s.q.data());
    for (double& x : s.v) x = d(rng);
    for (double& x : s.u) x = 0.5 * d(rng);
  }
  return pool;
}

double difference(const std::vector<double>& a, const std::vector<double>& b) {
  double diff = 0, size = 1;
  for (std::size_t i = 0; i < a.size(); ++i) {
    diff = std::max(diff, std::abs(a[i] - b[i]));
    size = std::max(size, std::abs(b[i]));
  }
  return std::isnan(diff) ? INFINITY : diff / size;
}

// Rows: R (the default form), straight: S; the same model and sets.
template <class R, class S> void run(const char* robot) {
  static_assert(R::nv == S::nv && R::ncontact_sets == S::ncontact_sets);
  constexpr int nv = R::nv, nu = R::nu;
  const std::vector<State> pool = states<R>(7);
  for (int s = 0; s < R::ncontact_sets; ++s) {
    const int rows = R::contact_rows[s];
    const std::string set(R::contact_set_names[s]);
    // every output of a kernel in one array: the velocity blocks, then the force blocks
    std::vector<double> a(2 * nv * nv + nv * nu + 2 * rows * nv + rows * nu), b(a.size());
    auto contact = [&](auto kernels, const State& x, std::vector<double>& out) {
      double* o = out.data();
      return decltype(kernels)::contact_dynamics_derivatives(
          s, 0.0, x.q.data(), x.v.data(), x.u.data(), nullptr, 5.0, 0.0, o, o + nv * nv, o + 2 * nv * nv,
          o + 2 * nv * nv + nv * nu, o + 2 * nv * nv + nv * nu + rows * nv, o + 2 * nv * nv + nv * nu + 2 * rows * nv);
    };
    auto impulse = [&](auto kernels, const State& x, std::vector<double>& out) {
      double* o = out.data();
      return decltype(kernels)::impulse_dynamics_derivatives(s, x.q.data(), x.v.data(), nullptr, 0.5, 0.0, o,
                                                             o + nv * nv, o + 2 * nv * nv, o + 2 * nv * nv + rows * nv);
    };
    double worst_c = 0, worst_i = 0;
    for (const State& x : pool) {
      if (!contact(R{}, x, a) || !contact(S{}, x, b)) std::printf("%s %s: contact derivatives failed\n", robot, set.c_str());
      worst_c = std::max(worst_c, difference(a, b));
      if (!impulse(R{}, x, a) || !impulse(S{}, x, b)) std::printf("%s %s: impulse derivatives failed\n", robot, set.c_str());
      worst_i = std::max(worst_i, difference(a, b));
    }
    std::printf("%s %s: rows against straight-line, contact_dynamics_derivatives %.1e, "
                "impulse_dynamics_derivatives %.1e\n",
                robot, set.c_str(), worst_c, worst_i);
    const std::string c = std::string(robot) + " " + set + " contact_dynamics_derivatives rows/straight";
    eombench::compare(
        c.c_str(), [&](int i) { contact(R{}, pool[i % pool.size()], a); eombench::sink = a[0]; },
        [&](int i) { contact(S{}, pool[i % pool.size()], b); eombench::sink = b[0]; });
    const std::string m = std::string(robot) + " " + set + " impulse_dynamics_derivatives rows/straight";
    eombench::compare(
        m.c_str(), [&](int i) { impulse(R{}, pool[i % pool.size()], a); eombench::sink = a[0]; },
        [&](int i) { impulse(S{}, pool[i % pool.size()], b); eombench::sink = b[0]; });
  }
}

}  // namespace

int main() {
  run<forms_solo12::Kernels, forms_solo12_unrolled::Kernels>("Solo12");
  run<forms_humanoid::Kernels, forms_humanoid_unrolled::Kernels>("humanoid");
}
