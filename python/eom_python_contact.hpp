// Python bindings of the contact step (docs/CONTRACT.md §1, "Stepping with contact") for a model
// whose header states its scene (an MJCF model), added by add_eom_python_module() to the module
// bind_model() makes (python/README.md):
//   rollout(x0, steps, u=None, p=None, t0=0.0) -> (times (k,), states (k, nq + nv), status)
//     x = [q, v]; u one row held or one row per step (steps, nu); status 'ok' or why the step
//     after the last row failed ('dynamics_failed', 'unmodeled_pair', 'solver_failed')
//   contact_step(x, u=None, p=None, t=0.0) -> (t, x, status): one step
//   timestep: the model's (<option timestep>)
#pragma once

#include <memory>
#include <vector>

#include "eom/contact/step.hpp"
#include "eom_python.hpp"

namespace eom::python {

inline const char* step_status_name(StepStatus s) noexcept {
  switch (s) {
    case StepStatus::ok: return "ok";
    case StepStatus::dynamics_failed: return "dynamics_failed";
    case StepStatus::unmodeled_pair: return "unmodeled_pair";
    case StepStatus::solver_failed: return "solver_failed";
  }
  return "unknown";
}

template <class K, class Scene> void bind_contact_simulation(py::module_& m) {
  if constexpr (HasMassMatrix<K> && HasForwardDynamics<K>) {
    using M = Model<K>;
    constexpr int nq = M::nq, nv = M::nv, nu = M::nu, np = M::np, n = nq + nv;
    using namespace py::literals;
    const auto none = py::none();
    m.attr("timestep") = Scene::solver_options.timestep;

    // Steps from x with u[k] at step k (or one u held), writing each state after a step.
    auto run = [](const Input& X, const Input& U, const Input& P, long steps, double t,
                  std::vector<double>& times, std::vector<double>& states) {
      auto stepper = std::make_unique<ContactStepper<K, Scene>>();
      std::array<double, nq> q;
      std::array<double, nv> v;
      std::copy(X.data, X.data + nq, q.begin());
      std::copy(X.data + nq, X.data + n, v.begin());
      auto keep = [&] {
        times.push_back(t);
        states.insert(states.end(), q.begin(), q.end());
        states.insert(states.end(), v.begin(), v.end());
      };
      keep();
      StepStatus status = StepStatus::ok;
      py::gil_scoped_release release;
      for (long k = 0; k < steps && status == StepStatus::ok; ++k) {
        status = contact_step<K, Scene>(*stepper, t, q, v, nu > 0 ? U.row(k) : nullptr,
                                        np > 0 ? P.data : nullptr);
        if (status == StepStatus::ok) keep();
      }
      return status;
    };

    m.def("rollout", [run](py::handle x0, long steps, py::handle u, py::handle p, double t0) {
      Call c("rollout");
      if (steps < 0) fail("rollout", "steps", "must be >= 0, given " + std::to_string(steps));
      const Input X = c.input("x0", x0, n, nullptr, false);
      const Input U = c.input("u", u, nu, M::zero_inputs(), true);
      if (U.rows >= 0 && U.rows != steps)
        fail("rollout", "u", "expected (" + std::to_string(nu) + ",) held or (steps, " +
                                 std::to_string(nu) + ") = (" + std::to_string(steps) + ", " +
                                 std::to_string(nu) + "), given " + std::to_string(U.rows) + " rows");
      const Input P = c.input("p", p, np, M::parameters(), false);
      std::vector<double> times, states;
      times.reserve(static_cast<std::size_t>(steps) + 1);
      states.reserve((static_cast<std::size_t>(steps) + 1) * n);
      const StepStatus status = run(X, U, P, steps, t0, times, states);
      const index k = static_cast<index>(times.size());
      py::array_t<double> T(k), S({k, index{n}});
      std::copy(times.begin(), times.end(), T.mutable_data());
      std::copy(states.begin(), states.end(), S.mutable_data());
      return py::make_tuple(T, S, step_status_name(status));
    }, "x0"_a, "steps"_a, "u"_a = none, "p"_a = none, "t0"_a = 0.0,
       "Steps x = [q, v] `steps` times with eom::contact_step (MuJoCo's step with contact, "
       "friction and limits at the model's timestep and by its integrator, Euler or RK4): (times (k,), states (k, nq + nv), "
       "status), the state at t0 and after every step; status 'ok' or why the next step failed "
       "(the last row is then the last good state). u: one row held, or (steps, nu), one per step.");

    m.def("contact_step", [run](py::handle x, py::handle u, py::handle p, double t) {
      Call c("contact_step");
      const Input X = c.input("x", x, n, nullptr, false);
      const Input U = c.input("u", u, nu, M::zero_inputs(), false);
      const Input P = c.input("p", p, np, M::parameters(), false);
      std::vector<double> times, states;
      const StepStatus status = run(X, U, P, 1, t, times, states);
      py::array_t<double> S(index{n});
      std::copy(states.end() - n, states.end(), S.mutable_data());
      return py::make_tuple(times.back(), S, step_status_name(status));
    }, "x"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0,
       "One step of eom::contact_step from x = [q, v] at t: (t + h, x after it, status); on a "
       "status other than 'ok', x and t as given.");
  }
}

}  // namespace eom::python
