// Python bindings of the contact step (docs/CONTRACT.md §1, "Stepping with contact") for a model
// whose header states its scene (an MJCF model), added by add_eom_python_module() to the module
// bind_model() makes (python/README.md):
//   rollout(x0, steps, u=None, p=None, t0=0.0, threads=0) -> (times (k,), states (k, nq + nv), status)
//     x = [q, v]; u one row held or one row per step (steps, nu); status 'ok' or why the step
//     after the last row failed ('dynamics_failed', 'unmodeled_pair', 'solver_failed');
//     x0 (n, nq + nv): n cases on threads (eom::contact_rollout) -> (times (steps + 1,),
//     states (n, steps + 1, nq + nv), status: a list of n)
//   contact_step(x, u=None, p=None, t=0.0) -> (t, x, status): one step
//   forward(x, u=None, p=None, t=0.0) -> (qacc (nv,), contacts, status): MuJoCo's mj_forward at x
//     (eom::contact_forward); contacts a dict of arrays, one row per contact: geom1, geom2
//     (indices into geom_names), dist, pos (k, 3), frame (k, 3, 3: the normal, then the
//     tangents), force (k, 6: in the frame, as mj_contactForce), active (has constraint rows);
//     x (n, nq + nv), u (n, nu) or p (n, np): n states -> (qacc (n, nv), n dicts, n statuses)
//   geom_names: the scene's geoms, in MuJoCo's order
//   qpos0: where MuJoCo's mj_resetData starts (nq,); keyframes: the file's <key>s in its order,
//     each a dict: name ('' where unnamed), time, qpos (nq,), qvel (nv,), ctrl (nu,)
//   step_derivatives(x, u=None, p=None, t=0.0) -> (t, x, A (2nv, 2nv), B (2nv, nu), status): one
//     step and its Jacobians (eom::contact_step_derivatives; Euler models only)
//   timestep: the model's (<option timestep>)
#pragma once

#include <limits>
#include <memory>
#include <vector>

#include "eom/contact/rollout.hpp"
#include "eom/contact/step.hpp"
#include "eom/contact/step_derivatives.hpp"
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

    // One state's arguments (step_derivatives): x = [q, v] split, u and p as the kernels
    // take them (defaults where None), the arrays kept alive with them.
    struct OneState {
      Input X, U, P;
      std::array<double, nq> q;
      std::array<double, nv> v;
      const double* u() const noexcept { return nu > 0 ? U.data : nullptr; }
      const double* p() const noexcept { return np > 0 ? P.data : nullptr; }
    };
    auto one_state = [](Call& c, py::handle x, py::handle u, py::handle p) {
      OneState s{c.input("x", x, n, nullptr, false), c.input("u", u, nu, M::zero_inputs(), false),
                 c.input("p", p, np, M::parameters(), false), {}, {}};
      std::copy(s.X.data, s.X.data + nq, s.q.begin());
      std::copy(s.X.data + nq, s.X.data + n, s.v.begin());
      return s;
    };

    // n cases at once (x0 (n, nq + nv)) through eom::contact_rollout on threads: each case bitwise
    // its own rollout().
    auto cases = [](py::array X0, long steps, py::handle u, py::handle p, double t0, unsigned threads) {
      const index count = X0.shape(0);
      if (X0.shape(1) != n || count == 0)
        fail("rollout", "x0", "expected shape (" + std::to_string(nq + nv) + ",) or (n, " + std::to_string(n) +
                                  ") with n >= 1, given " + shape_text(X0.shape(), 2));
      const auto* x = static_cast<const double*>(X0.data());
      std::vector<double> q0(static_cast<std::size_t>(count * nq)), v0(static_cast<std::size_t>(count * nv));
      for (index c = 0; c < count; ++c) {
        std::copy(x + c * n, x + c * n + nq, q0.begin() + c * nq);
        std::copy(x + c * n + nq, x + (c + 1) * n, v0.begin() + c * nv);
      }
      // u: (nu,) held by all, (n, nu) one held per case, (n, steps, nu) per case and step; p: (np,)
      // or (n, np). Checked here so that the message names Python's shapes.
      const auto shaped = [&](const char* name, py::handle obj, index size, const double* fallback,
                              bool per_step, py::array& hold) -> std::span<const double> {
        if (obj.is_none()) return {fallback, static_cast<std::size_t>(size)};
        hold = float64_array("rollout", name, obj);
        const index nd = hold.ndim(), *shape = hold.shape();
        const bool fits = (nd == 1 && shape[0] == size) || (nd == 2 && shape[0] == count && shape[1] == size) ||
                          (per_step && nd == 3 && shape[0] == count && shape[1] == steps && shape[2] == size);
        if (!fits)
          fail("rollout", name, "expected shape (" + std::to_string(size) + ",) or (n, " + std::to_string(size) + ")" +
                                    (per_step ? " or (n, steps, " + std::to_string(size) + ")" : std::string()) +
                                    " with n = " + std::to_string(count) + " cases, given " + shape_text(shape, nd));
        if (size == 0) return {};
        return {static_cast<const double*>(hold.data()), static_cast<std::size_t>(hold.size())};
      };
      py::array hold_u, hold_p;
      const std::span<const double> U = shaped("u", u, nu, M::zero_inputs(), true, hold_u);
      const std::span<const double> P = shaped("p", p, np, M::parameters(), false, hold_p);
      RolloutOptions opt{.steps = steps, .t0 = t0, .threads = threads != 0 ? threads : thread_count(), .record = true};
      RolloutResult r;
      {
        py::gil_scoped_release release;
        r = contact_rollout<K, Scene>(RolloutCases{q0, v0, nu > 0 ? U : std::span<const double>(),
                                                   np > 0 ? P : std::span<const double>()},
                                      opt);
      }
      if (!r.ok()) throw py::value_error("rollout: " + r.error);
      py::array_t<double> T(steps + 1), S({count, index{steps + 1}, index{n}});
      double t = t0;  // as each step advances it: bitwise every case's time
      for (long k = 0; k <= steps; ++k) T.mutable_data()[k] = t, t += Scene::solver_options.timestep;
      std::copy(r.states.begin(), r.states.end(), S.mutable_data());
      py::list status;
      for (const RolloutCase& one : r.cases) status.append(step_status_name(one.status));
      return py::make_tuple(T, S, status);
    };

    m.def("rollout", [run, cases](py::handle x0, long steps, py::handle u, py::handle p, double t0, unsigned threads) {
      Call c("rollout");
      if (steps < 0) fail("rollout", "steps", "must be >= 0, given " + std::to_string(steps));
      if (!x0.is_none()) {
        py::array X0 = float64_array("rollout", "x0", x0);
        if (X0.ndim() == 2) return cases(std::move(X0), steps, u, p, t0, threads);
      }
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
    }, "x0"_a, "steps"_a, "u"_a = none, "p"_a = none, "t0"_a = 0.0, "threads"_a = 0u,
       "Steps x = [q, v] `steps` times with eom::contact_step (MuJoCo's step with contact, "
       "friction and limits at the model's timestep and by its integrator, Euler or RK4): (times (k,), states (k, nq + nv), "
       "status), the state at t0 and after every step; status 'ok' or why the next step failed "
       "(the last row is then the last good state). u: one row held, or (steps, nu), one per step. "
       "x0 (n, nq + nv): n cases on threads (eom::contact_rollout; threads 0: set_num_threads'), each "
       "bitwise its own rollout: (times (steps + 1,), states (n, steps + 1, nq + nv), status: n names), "
       "a case's rows NaN after its failed step; u (nu,) held by all, (n, nu) per case or "
       "(n, steps, nu) per case and step; p (np,) or (n, np).");

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

    {
      py::list names;
      for (const Geom& g : Scene::geoms) names.append(g.name);
      m.attr("geom_names") = py::tuple(names);
    }
    // where to start: MuJoCo's qpos0 and the file's keyframes
    m.attr("qpos0") = constant_array(Scene::qpos0);
    {
      py::list keys;
      for (const auto& key : Scene::keyframes)
        keys.append(py::dict("name"_a = key.name, "time"_a = key.time, "qpos"_a = constant_array(key.qpos),
                             "qvel"_a = constant_array(key.qvel), "ctrl"_a = constant_array(key.ctrl)));
      m.attr("keyframes") = py::tuple(keys);
    }

    // MuJoCo's mj_forward at x = [q, v] (cold-started: the state's answer alone, whatever the
    // stepper saw before): qacc into `qacc` (NaN on a failed status) and the contacts as a dict.
    auto forward_at = [](ContactStepper<K, Scene>& stepper, double t, const double* x, const double* u,
                         const double* p, double* qacc) {
      std::array<double, nq> q;
      std::array<double, nv> v;
      std::copy(x, x + nq, q.begin());
      std::copy(x + nq, x + n, v.begin());
      StepStatus status;
      {
        py::gil_scoped_release release;
        status = contact_forward<K, Scene>(stepper, t, q, v, u, p);
      }
      const bool ok = status == StepStatus::ok;
      const ConstraintRows<Scene>& rows = stepper.rows;
      const index k = ok ? rows.ncontacts : 0;  // (no contacts where the step would fail)
      py::array_t<double> dist(k), pos(std::vector<index>{k, 3}), frame(std::vector<index>{k, 3, 3}),
          force(std::vector<index>{k, 6});
      py::array_t<int> geom1(k), geom2(k);
      py::array_t<bool> active(k);
      for (int i = 0; i < nv; ++i) qacc[i] = ok ? stepper.solution.qacc[i] : std::numeric_limits<double>::quiet_NaN();
      for (index c = 0; c < k; ++c) {
        const Contact& contact = rows.contacts[c];
        const CollisionPair& pair = Scene::collision_pairs[rows.contact_pair[c]];
        geom1.mutable_data()[c] = pair.geom1, geom2.mutable_data()[c] = pair.geom2;
        dist.mutable_data()[c] = contact.dist;
        std::copy(contact.pos.begin(), contact.pos.end(), pos.mutable_data() + 3 * c);
        std::copy(contact.frame.begin(), contact.frame.end(), frame.mutable_data() + 9 * c);
        const std::array<double, 6> f = contact_force<Scene>(rows, stepper.solution, static_cast<int>(c));
        std::copy(f.begin(), f.end(), force.mutable_data() + 6 * c);
        active.mutable_data()[c] = rows.contact_row[c] >= 0;
      }
      py::dict contacts("geom1"_a = geom1, "geom2"_a = geom2, "dist"_a = dist, "pos"_a = pos,
                        "frame"_a = frame, "force"_a = force, "active"_a = active);
      return std::make_pair(contacts, status);
    };

    m.def("forward", [forward_at](py::handle x, py::handle u, py::handle p, double t) {
      Call c("forward");
      const Input X = c.input("x", x, n), U = c.input("u", u, nu, M::zero_inputs()),
                  P = c.input("p", p, np, M::parameters());
      const bool batch = X.rows >= 0 || U.rows >= 0 || P.rows >= 0;
      const index count = c.rows();
      py::array_t<double> qacc = batch ? py::array_t<double>(std::vector<index>{count, nv})
                                       : py::array_t<double>(index{nv});
      auto stepper = std::make_unique<ContactStepper<K, Scene>>();
      py::list contacts, status;
      for (index i = 0; i < count; ++i) {
        auto [dict, s] = forward_at(*stepper, t, X.row(i), nu > 0 ? U.row(i) : nullptr, np > 0 ? P.row(i) : nullptr,
                                    qacc.mutable_data() + i * nv);
        contacts.append(std::move(dict));
        status.append(step_status_name(s));
      }
      if (batch) return py::make_tuple(qacc, contacts, status);
      return py::make_tuple(qacc, contacts[0], status[0]);
    }, "x"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0,
       "MuJoCo's mj_forward at x = [q, v] (eom::contact_forward): (qacc (nv,), contacts, status). "
       "qacc: the constrained acceleration (damping explicit, as mj_forward's qacc). contacts: a "
       "dict of arrays with one row per contact, in MuJoCo's order: geom1, geom2 (indices into "
       "geom_names), dist (signed distance), pos (k, 3: midway), frame (k, 3, 3: row 0 the normal, "
       "from geom1 towards geom2, then the tangents), force (k, 6: the force geom1 applies to geom2 "
       "in that frame, normal first, then friction, torsional and rolling, as mj_contactForce), "
       "active (whether it has constraint rows: within margin - gap). On a status other than "
       "'ok', qacc NaN and no contacts. x (n, nq + nv), u (n, nu) or p (n, np): n states, each "
       "bitwise its own call: (qacc (n, nv), a list of n contact dicts, a list of n statuses).");

    if constexpr (Scene::solver_options.integrator == 0)
      m.def("step_derivatives", [one_state](py::handle x, py::handle u, py::handle p, double t) {
        Call c("step_derivatives");
        OneState s = one_state(c, x, u, p);
        auto stepper = std::make_unique<ContactStepper<K, Scene>>();
        auto d = std::make_unique<StepDerivatives<K, Scene>>();
        auto& q = s.q;
        auto& v = s.v;
        StepStatus status;
        {
          py::gil_scoped_release release;
          status = contact_step_derivatives<K, Scene>(*stepper, *d, t, q, v, s.u(), s.p());
        }
        py::array_t<double> S(index{n}), A(std::vector<index>{2 * nv, 2 * nv}), B(std::vector<index>{2 * nv, nu});
        std::copy(q.begin(), q.end(), S.mutable_data());
        std::copy(v.begin(), v.end(), S.mutable_data() + nq);
        const bool ok = status == StepStatus::ok;
        const double nan = std::numeric_limits<double>::quiet_NaN();
        for (int i = 0; i < 2 * nv; ++i) {  // row-major out of the column-major Jacobians
          for (int j = 0; j < 2 * nv; ++j) A.mutable_data()[2 * nv * i + j] = ok ? d->A[i + 2 * nv * j] : nan;
          for (int j = 0; j < nu; ++j) B.mutable_data()[nu * i + j] = ok ? d->B[i + 2 * nv * j] : nan;
        }
        return py::make_tuple(t, S, A, B, step_status_name(status));
      }, "x"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0,
         "One step from x = [q, v] at t as contact_step, and its Jacobians at x "
         "(eom::contact_step_derivatives): (t + h, x after it, A = ∂x⁺/∂x (2nv, 2nv), B = ∂x⁺/∂u "
         "(2nv, nu), status), x = (δq, v) with δq along the tangent directions (a quaternion's in "
         "its moving axes), as MuJoCo's mjd_transitionFD; on a status other than 'ok', x and t as "
         "given and A, B NaN.");
  }
}

}  // namespace eom::python
