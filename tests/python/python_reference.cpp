// The C++ side of the Python tests (tests/python/test_*.py): every kernel of each model at one
// state, and eom::integrate / eom::ensemble runs, written as JSON with every double exact
// (%.17g). The tests call the Python module with the same inputs (read from this file) and compare.
//
//   python_reference <out.json>
//   python_reference --bench <n>   # the C++ loop examples/python/benchmark.py compares with:
//                                  # forward_dynamics over n states, ns per state (best of 5)
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <eom/ensemble/ensemble.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/model/kernels.hpp>

#include <cartesian_pendulum.hpp>
#include <chain10.hpp>
#include <frame_arm.hpp>
#include <panda.hpp>
#include <py_pendulum.hpp>
#include <spacecraft_free.hpp>

namespace {

std::FILE* out = nullptr;

void number(double x) {
  if (std::isnan(x)) std::fputs("NaN", out);
  else if (std::isinf(x)) std::fputs(x > 0 ? "Infinity" : "-Infinity", out);
  else std::fprintf(out, "%.17g", x);
}

void array(const double* x, int n) {
  std::fputc('[', out);
  for (int i = 0; i < n; ++i) {
    if (i > 0) std::fputc(',', out);
    number(x[i]);
  }
  std::fputc(']', out);
}

// "name": {"result": r, "outputs": [[...], ...]}
struct Entry {
  bool first = true;
  void begin(const std::string& name) {
    std::fprintf(out, "%s\n  \"%s\": {", first ? "" : ",", name.c_str());
    first = false;
  }
  void end() { std::fputc('}', out); }
};

// The state the tests use for a model: deterministic, q's quaternion unit for a free joint.
template <class K> struct Inputs {
  static constexpr int nq = K::nq, nv = eom::nv_of<K>, nu = K::nu, np = K::np;
  std::array<double, nq> q{};
  std::array<double, nv> qd{}, qdd{};
  std::array<double, (nu > 0 ? nu : 1)> u{};
  std::array<double, (np > 0 ? np : 1)> p{};
  double t = 0.25;
  Inputs() {
    for (int i = 0; i < nq; ++i) q[i] = 0.3 + 0.1 * i - 0.013 * i * i;
    for (int i = 0; i < nv; ++i) qd[i] = 0.2 - 0.05 * i, qdd[i] = 0.1 * i - 0.4;
    for (int i = 0; i < nu; ++i) u[i] = 0.5 - 0.1 * i;
    for (int i = 0; i < np; ++i) p[i] = K::parameter_values[i];
    if constexpr (nv != nq) {  // a free joint: a unit quaternion
      double s = 0;
      for (int i = 3; i < 7; ++i) s += q[i] * q[i];
      for (int i = 3; i < 7; ++i) q[i] /= std::sqrt(s);
    }
  }
};

template <class K> void kernels(const char* model, bool first_model) {
  using namespace eom;
  constexpr int nq = K::nq, nv = nv_of<K>, nu = K::nu, np = K::np, nc = K::nc;
  const Inputs<K> in;
  const double *q = in.q.data(), *qd = in.qd.data(), *qdd = in.qdd.data(), *u = in.u.data(), *p = in.p.data();
  const double t = in.t;
  std::fprintf(out, "%s\n\"%s\": {\"inputs\": {\"q\": ", first_model ? "" : ",", model);
  array(q, nq);
  std::fputs(", \"qd\": ", out);
  array(qd, nv);
  std::fputs(", \"qdd\": ", out);
  array(qdd, nv);
  std::fputs(", \"u\": ", out);
  array(u, nu);
  std::fputs(", \"p\": ", out);
  array(p, np);
  std::fputs(", \"t\": ", out);
  number(t);
  // The generated header's names and limits, as the module should show them.
  std::fputs("},\n \"header\": {", out);
  auto names = [&](const char* key, const auto& list, bool last = false) {
    std::fprintf(out, "\"%s\": [", key);
    for (std::size_t i = 0; i < list.size(); ++i)
      std::fprintf(out, "%s\"%.*s\"", i ? "," : "", static_cast<int>(list[i].size()), list[i].data());
    std::fputs(last ? "]" : "], ", out);
  };
  auto values = [&](const char* key, const auto& list, bool last = false) {
    std::fprintf(out, "\"%s\": ", key);
    array(list.data(), static_cast<int>(list.size()));
    std::fputs(last ? "" : ", ", out);
  };
  names("coordinate_names", K::coordinate_names);
  names("velocity_names", K::velocity_names);
  names("input_names", K::input_names);
  values("position_lower", K::position_lower);
  values("position_upper", K::position_upper);
  values("effort_limit", K::effort_limit);
  values("velocity_limit", K::velocity_limit, true);
  std::fputs("},\n \"kernels\": {", out);
  Entry e;
  std::vector<double> a(2000), b(2000), c(2000);
  auto outputs = [&](std::initializer_list<std::pair<const std::vector<double>*, int>> list) {
    std::fputs("\"outputs\": [", out);
    bool first = true;
    for (auto [v, n] : list) {
      if (!first) std::fputc(',', out);
      first = false;
      array(v->data(), n);
    }
    std::fputs("]", out);
  };
  auto result = [&](bool ok) { std::fprintf(out, "\"result\": %s, ", ok ? "true" : "false"); };
  if constexpr (HasMassMatrix<K>) {
    e.begin("mass_matrix"), K::mass_matrix(q, p, a.data()), outputs({{&a, nv * nv}}), e.end();
  }
  if constexpr (HasMassMatrixDot<K>) {
    e.begin("mass_matrix_dot"), K::mass_matrix_dot(q, qd, p, a.data()), outputs({{&a, nv * nv}}), e.end();
  }
  if constexpr (HasCoriolis<K>) {
    e.begin("coriolis"), K::coriolis(q, qd, p, a.data()), outputs({{&a, nv}}), e.end();
  }
  if constexpr (HasPotentialGradient<K>) {
    e.begin("potential_gradient"), K::potential_gradient(q, p, a.data()), outputs({{&a, nv}}), e.end();
  }
  if constexpr (HasGeneralizedForces<K>) {
    e.begin("generalized_forces"), K::generalized_forces(t, q, qd, u, p, a.data()), outputs({{&a, nv}}), e.end();
  }
  if constexpr (HasConstraintResidual<K>) {
    e.begin("constraint_residual"), K::constraint_residual(q, p, a.data()), outputs({{&a, nc}}), e.end();
  }
  if constexpr (HasConstraintJacobian<K>) {
    e.begin("constraint_jacobian"), K::constraint_jacobian(q, p, a.data()), outputs({{&a, nc * nv}}), e.end();
  }
  if constexpr (HasConstraintBias<K>) {
    e.begin("constraint_bias"), K::constraint_bias(q, qd, p, a.data()), outputs({{&a, nc}}), e.end();
  }
  if constexpr (HasForwardDynamics<K>) {
    e.begin("forward_dynamics"), result(K::forward_dynamics(t, q, qd, u, p, a.data()));
    outputs({{&a, nv}}), e.end();
  }
  if constexpr (HasKineticEnergy<K>) {
    a[0] = K::kinetic_energy(q, qd, p);
    e.begin("kinetic_energy"), outputs({{&a, 1}}), e.end();
  }
  if constexpr (HasPotentialEnergy<K>) {
    a[0] = K::potential_energy(q, p);
    e.begin("potential_energy"), outputs({{&a, 1}}), e.end();
  }
  if constexpr (HasForwardDynamicsDerivatives<K>) {
    e.begin("forward_dynamics_derivatives");
    result(K::forward_dynamics_derivatives(t, q, qd, u, p, a.data(), b.data(), c.data()));
    outputs({{&a, nv * nv}, {&b, nv * nv}, {&c, nv * nu}}), e.end();
  }
  if constexpr (HasInverseDynamics<K>) {
    e.begin("inverse_dynamics"), K::inverse_dynamics(t, q, qd, qdd, u, p, a.data());
    outputs({{&a, nv}}), e.end();
  }
  if constexpr (HasTaylorCoefficients<K>) {
    constexpr int order = 4;
    std::vector<double> work(static_cast<std::size_t>(K::taylor_workspace) * (order + 1));
    e.begin("taylor_coefficients");
    result(K::taylor_coefficients(order, t, q, qd, u, p, a.data(), b.data(), work.data()));
    std::fprintf(out, "\"order\": %d, ", order);
    outputs({{&a, nq * (order + 1)}, {&b, nv * (order + 1)}}), e.end();
  }
  if constexpr (HasForwardDynamicsParameterDerivatives<K>) {
    e.begin("forward_dynamics_parameter_derivatives");
    result(K::forward_dynamics_parameter_derivatives(t, q, qd, u, p, a.data()));
    outputs({{&a, nv * np}}), e.end();
  }
  if constexpr (HasInverseDynamicsDerivatives<K>) {
    e.begin("inverse_dynamics_derivatives"), K::inverse_dynamics_derivatives(t, q, qd, qdd, u, p, a.data(), b.data());
    outputs({{&a, nv * nv}, {&b, nv * nv}}), e.end();
  }
  if constexpr (HasFramePlacement<K>) {
    for (int f = 0; f < K::nframes; ++f) {
      e.begin("frame_placement/" + std::to_string(f)), K::frame_placement(f, q, p, a.data(), b.data());
      outputs({{&a, 3}, {&b, 9}}), e.end();
    }
  }
  if constexpr (HasFrameJacobian<K>) {
    for (int f = 0; f < K::nframes; ++f) {
      e.begin("frame_jacobian/" + std::to_string(f)), K::frame_jacobian(f, q, p, a.data());
      outputs({{&a, 6 * nv}}), e.end();
    }
  }
  if constexpr (HasFrameAccelerationBias<K>) {
    for (int f = 0; f < K::nframes; ++f) {
      e.begin("frame_acceleration_bias/" + std::to_string(f)), K::frame_acceleration_bias(f, q, qd, p, a.data());
      outputs({{&a, 6}}), e.end();
    }
  }
  if constexpr (HasCenterOfMass<K>) {
    e.begin("center_of_mass"), K::center_of_mass(q, p, a.data()), outputs({{&a, 3}}), e.end();
  }
  if constexpr (HasCenterOfMassJacobian<K>) {
    e.begin("center_of_mass_jacobian"), K::center_of_mass_jacobian(q, p, a.data()), outputs({{&a, 3 * nv}}), e.end();
  }
  if constexpr (HasCentroidalMomentumMatrix<K>) {
    e.begin("centroidal_momentum_matrix"), K::centroidal_momentum_matrix(q, p, a.data());
    outputs({{&a, 6 * nv}}), e.end();
  }
  std::fputs("}}", out);
}

// One eom::integrate run: {"method": ..., "t0", "t1", "rtol", "atol", "step", "t_eval", "u",
// "x0", "times", "states", "status"}.
template <class K>
void integration(const char* name, const char* model, eom::Method method, double t1, double rtol, double step,
                 std::vector<double> t_eval, bool with_u) {
  const Inputs<K> in;
  constexpr int nq = K::nq, nv = eom::nv_of<K>, m = nq + nv;
  eom::StateFor<K> x0;
  for (int i = 0; i < nq; ++i) x0[i] = in.q[i];
  for (int i = 0; i < nv; ++i) x0[nq + i] = in.qd[i];
  std::array<double, (K::nu > 0 ? K::nu : 1)> u{};
  if (with_u) u = in.u;
  eom::IntegrationOptions opt;
  opt.method = method;
  opt.rtol = rtol, opt.atol = rtol * 1e-2, opt.step = step;
  opt.output_times = t_eval;
  std::vector<double> times, states;
  const auto r = eom::integrate<K>(0.0, t1, x0, K::nu > 0 ? u.data() : nullptr, in.p.data(), opt,
                                   [&](double t, const eom::StateFor<K>& x) {
                                     times.push_back(t);
                                     states.insert(states.end(), x.begin(), x.end());
                                   });
  std::fprintf(out, ",\n  \"%s\": {\"model\": \"%s\", \"method\": \"%s\", \"t1\": ", name, model,
               eom::to_string(method));
  number(t1);
  std::fputs(", \"rtol\": ", out);
  number(opt.rtol);
  std::fputs(", \"atol\": ", out);
  number(opt.atol);
  std::fputs(", \"step\": ", out);
  number(step);
  std::fputs(", \"t_eval\": ", out);
  if (t_eval.empty()) std::fputs("null", out);
  else array(t_eval.data(), static_cast<int>(t_eval.size()));
  std::fputs(", \"u\": ", out);
  if (with_u) array(u.data(), K::nu);
  else std::fputs("null", out);
  std::fputs(", \"x0\": ", out);
  array(x0.data(), m);
  std::fputs(", \"times\": ", out);
  array(times.data(), static_cast<int>(times.size()));
  std::fputs(", \"states\": ", out);
  array(states.data(), static_cast<int>(states.size()));
  std::fprintf(out, ", \"status\": \"%s\"}", eom::to_string(r.status));
}

// eom::ensemble over 9 cases of chain10 (x0 perturbed case by case), RK4 (through the batch
// kernel) and dop853, sampled at t_eval.
void ensembles() {
  using K = chain10::Kernels;
  const Inputs<K> in;
  constexpr int n = K::nq, m = 2 * n, cases = 9;
  std::vector<eom::StateOf<n>> x0(cases);
  for (int c = 0; c < cases; ++c)
    for (int i = 0; i < m; ++i) x0[c][i] = (i < n ? in.q[i] : in.qd[i - n]) + 0.01 * c * (i % 3);
  const std::vector<double> t_eval{0.0, 0.1, 0.25, 0.4};
  for (auto method : {eom::Method::rk4, eom::Method::dop853}) {
    eom::EnsembleOptions opt;
    opt.t0 = 0, opt.t1 = 0.4, opt.threads = 2;
    opt.integration.method = method;
    opt.integration.step = method == eom::Method::rk4 ? 0.01 : 0.0;
    opt.sample_times = t_eval;
    const auto r = eom::ensemble<K>({x0, std::span<const double>(in.p.data(), K::np), {}}, opt);
    std::fprintf(out, ",\n  \"ensemble_%s\": {\"method\": \"%s\", \"t1\": 0.4, \"step\": ", eom::to_string(method),
                 eom::to_string(method));
    number(opt.integration.step);
    std::fputs(", \"t_eval\": ", out);
    array(t_eval.data(), static_cast<int>(t_eval.size()));
    std::fputs(", \"x0\": ", out);
    array(x0[0].data(), cases * m);
    std::fputs(", \"samples\": ", out);
    array(r.samples[0].data(), static_cast<int>(r.samples.size()) * m);
    std::fputs(", \"status\": [", out);
    for (int c = 0; c < cases; ++c) std::fprintf(out, "%s\"%s\"", c ? "," : "", eom::to_string(r.cases[c].status));
    std::fputs("]}", out);
  }
}

// forward_dynamics over n states of K in a plain loop: the best of 5 runs, ns per state.
template <class K> double loop_ns(const char* model, long n) {
  constexpr int nq = K::nq, nv = eom::nv_of<K>;
  std::vector<double> q(static_cast<std::size_t>(n) * nq), qd(static_cast<std::size_t>(n) * nv),
      qdd(static_cast<std::size_t>(n) * nv);
  unsigned s = 12345;
  const auto next = [&s] { return (s = s * 1103515245u + 12345u) / 4294967296.0 * 2 - 1; };
  for (auto& v : q) v = next();
  for (auto& v : qd) v = next();
  const Inputs<K> in;
  const double* u = in.u.data();
  double best = 1e300;
  long failures = 0;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    for (long i = 0; i < n; ++i)
      failures += !K::forward_dynamics(0.0, &q[i * nq], &qd[i * nv], u, in.p.data(), &qdd[i * nv]);
    const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, ns / static_cast<double>(n));
  }
  std::printf("%s forward_dynamics: %.1f ns per state (C++ loop over %ld states, best of 5; %ld failed)\n",
              model, best, n, failures / 5);
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--bench") {
    const long n = std::stol(argv[2]);
    loop_ns<chain10::Kernels>("chain10", n);
    loop_ns<panda::Kernels>("panda", n);
    return 0;
  }
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <out.json>\n", argv[0]);
    return 2;
  }
  out = std::fopen(argv[1], "w");
  if (out == nullptr) return 1;
  std::fputs("{\"models\": {", out);
  kernels<chain10::Kernels>("chain10", true);
  kernels<panda::Kernels>("panda", false);
  kernels<frame_arm::Kernels>("frame_arm", false);
  kernels<cartesian_pendulum::Kernels>("cartesian_pendulum", false);
  kernels<spacecraft_free::Kernels>("spacecraft_free", false);
  kernels<py_pendulum::Kernels>("py_pendulum", false);
  std::fputs("},\n\"runs\": {\"none\": null", out);
  using eom::Method;
  integration<chain10::Kernels>("chain10_dop853", "chain10", Method::dop853, 0.5, 1e-10, 0.0,
                                {0.0, 0.1, 0.2, 0.30000000000000004, 0.5}, false);
  integration<chain10::Kernels>("chain10_dopri5", "chain10", Method::dopri5, 0.3, 1e-8, 0.0, {}, false);
  integration<chain10::Kernels>("chain10_rk4", "chain10", Method::rk4, 0.2, 1e-8, 0.01, {}, false);
  integration<chain10::Kernels>("chain10_radau5", "chain10", Method::radau5, 0.2, 1e-8, 0.0, {}, false);
  integration<chain10::Kernels>("chain10_taylor", "chain10", Method::taylor, 0.3, 1e-12, 0.0, {0.05, 0.3}, false);
  integration<panda::Kernels>("panda_dop853", "panda", Method::dop853, 0.5, 1e-9, 0.0, {}, true);
  integration<spacecraft_free::Kernels>("spacecraft_free_dop853", "spacecraft_free", Method::dop853, 1.0, 1e-9,
                                        0.0, {0.0, 0.5, 1.0}, true);
  ensembles();
  std::fputs("}}\n", out);
  return std::fclose(out) == 0 ? 0 : 1;
}
