// The bodies of hard_cases.hpp's functions (see there), compiled once for the tests in this folder
// and bench/hard_cases.cpp. Like every unit that includes the header: -ffp-contract=off.
#include "hard_cases.hpp"

namespace hard_cases {

SphericalStart spherical_start(double theta0, double theta_min) {
  const auto& p = Polar::parameter_values;
  const double m = p[0], l = p[1], g = p[2];
  const double s0 = std::sin(theta0), smin = std::sin(theta_min);
  SphericalStart s;
  s.Lz = theta_min == 0 ? 0.0
                        : std::sqrt(2 * m * m * g * l * l * l * (std::cos(theta_min) - std::cos(theta0)) /
                                    (1 / (smin * smin) - 1 / (s0 * s0)));
  const double phid = s.Lz / (m * l * l * s0 * s0);
  s.polar = {theta0, 0.0, 0.0, phid};
  s.cartesian = {l * s0, 0.0, -l * std::cos(theta0), 0.0, l * s0 * phid, 0.0};
  s.energy = Polar::kinetic_energy(s.polar.data(), s.polar.data() + 2, p.data()) +
             Polar::potential_energy(s.polar.data(), p.data());
  return s;
}

SphericalStart spherical_start_from(const eom::StateOf<2>& x) {
  const auto& p = Polar::parameter_values;
  const double m = p[0], l = p[1], st = std::sin(x[0]), ct = std::cos(x[0]);
  const double sp = std::sin(x[1]), cp = std::cos(x[1]);
  SphericalStart s;
  s.polar = x;
  s.Lz = m * l * l * st * st * x[3];
  s.cartesian = {l * st * cp, l * st * sp, -l * ct, l * (ct * cp * x[2] - st * sp * x[3]),
                 l * (ct * sp * x[2] + st * cp * x[3]), l * st * x[2]};
  s.energy = Polar::kinetic_energy(x.data(), x.data() + 2, p.data()) +
             Polar::potential_energy(x.data(), p.data());
  return s;
}

std::array<double, 3> polar_position(const eom::StateOf<2>& x) {
  const double l = Polar::parameter_values[1];
  return {l * std::sin(x[0]) * std::cos(x[1]), l * std::sin(x[0]) * std::sin(x[1]),
          -l * std::cos(x[0])};
}

std::vector<std::array<double, 3>> spherical_reference(const SphericalStart& s,
                                                       const std::vector<double>& times,
                                                       double tolerance,
                                                       int columns) {
  std::array<dd_real, 6> x0;
  for (int i = 0; i < 6; ++i) x0[i] = dd_real(s.cartesian[i]);
  std::array<dd_real, 3> p;
  for (int i = 0; i < 3; ++i) p[i] = dd_real(Cartesian::parameter_values[i]);
  std::vector<std::array<double, 3>> out;
  eom::ExtrapolationOptions opt;
  opt.tolerance = tolerance;
  opt.columns = columns;
  const auto r = eom::extrapolate<eom::models::CartesianSphericalPendulum, dd_real>(
      0.0, x0, times, nullptr, p.data(), opt, [&](double, const std::array<dd_real, 6>& x) {
        out.push_back({to_double(x[0]), to_double(x[1]), to_double(x[2])});
      });
  if (r.status != eom::Status::ok) out.clear();
  return out;
}

PassageRun polar_run(eom::Method method, double tol, double h, const SphericalStart& s,
                     const std::vector<double>& times,
                     const std::vector<std::array<double, 3>>& ref) {
  const auto& p = Polar::parameter_values;
  const double ml2 = p[0] * p[1] * p[1];
  eom::IntegrationOptions opt;
  opt.method = method;
  if (tol > 0) opt.rtol = opt.atol = tol;  // fixed-step methods: tol = 0, step h
  opt.step = h;
  opt.output_times = times;
  opt.max_steps = 2000000;
  PassageRun run;
  std::size_t k = 0;
  const auto r = eom::integrate<Polar>(
      0.0, times.back(), s.polar, nullptr, p.data(), opt, [&](double, const eom::StateOf<2>& x) {
        run.finite = run.finite && all_finite(x);
        const auto r3 = polar_position(x);
        for (int i = 0; i < 3; ++i)
          run.position_error = std::max(run.position_error, std::abs(r3[i] - ref[k][i]));
        const double sn = std::sin(x[0]);
        run.lz_error = std::max(run.lz_error, std::abs(ml2 * sn * sn * x[3] - s.Lz));
        const double E = Polar::kinetic_energy(x.data(), x.data() + 2, p.data()) +
                         Polar::potential_energy(x.data(), p.data());
        run.energy_error = std::max(run.energy_error, std::abs(E - s.energy));
        ++k;
      });
  run.status = r.status, run.t_end = r.t, run.accepted = r.accepted, run.rejected = r.rejected;
  run.finite = run.finite && all_finite(r.x);
  return run;
}

PassageRun cartesian_run(eom::Method method, double tol, double h, const SphericalStart& s,
                         const std::vector<double>& times,
                         const std::vector<std::array<double, 3>>& ref) {
  const auto& p = Cartesian::parameter_values;
  eom::IntegrationOptions opt;
  opt.method = method;
  if (tol > 0) opt.rtol = opt.atol = tol;  // fixed-step methods: tol = 0, step h
  opt.step = h;
  opt.output_times = times;
  opt.max_steps = 2000000;
  opt.stabilization.method = eom::Stabilization::Method::projection;
  PassageRun run;
  std::size_t k = 0;
  const auto r = eom::integrate<Cartesian>(
      0.0, times.back(), s.cartesian, nullptr, p.data(), opt, [&](double, const eom::StateOf<3>& x) {
        run.finite = run.finite && all_finite(x);
        for (int i = 0; i < 3; ++i)
          run.position_error = std::max(run.position_error, std::abs(x[i] - ref[k][i]));
        run.lz_error = std::max(run.lz_error, std::abs(p[0] * (x[0] * x[4] - x[1] * x[3]) - s.Lz));
        const double E = Cartesian::kinetic_energy(x.data(), x.data() + 3, p.data()) +
                         Cartesian::potential_energy(x.data(), p.data());
        run.energy_error = std::max(run.energy_error, std::abs(E - s.energy));
        ++k;
      });
  run.status = r.status, run.t_end = r.t, run.accepted = r.accepted, run.rejected = r.rejected;
  run.finite = run.finite && all_finite(r.x);
  return run;
}

std::vector<double> uniform_times(double dt, double t1) {
  std::vector<double> t;
  for (int i = 1; i * dt <= t1 * (1 + 1e-12); ++i) t.push_back(i * dt);
  return t;
}

DoublePendulumReference double_pendulum_reference(double t1, double dt, double tolerance,
                                                  double perturbation) {
  using DP = eom::models::DoublePendulum;
  DoublePendulumReference ref;
  ref.times = uniform_times(dt, t1);
  std::array<dd_real, 5> p;
  for (int i = 0; i < 5; ++i) p[i] = dd_real(DP::parameter_values[i]);
  const std::array<dd_real, 4> x0{dd_real(DP::initial_q[0]) + dd_real(perturbation),
                                  dd_real(DP::initial_q[1]), dd_real(0.0), dd_real(0.0)};
  eom::ExtrapolationOptions opt;
  opt.tolerance = tolerance;
  opt.max_steps = 10000000;
  const auto r = eom::extrapolate<DP, dd_real>(
      0.0, x0, ref.times, nullptr, p.data(), opt, [&](double, const std::array<dd_real, 4>& x) {
        ref.x.push_back({to_double(x[0]), to_double(x[1]), to_double(x[2]), to_double(x[3])});
      });
  ref.status = r.status;
  ref.steps = r.accepted;
  return ref;
}

double max_difference(const DoublePendulumState& a, const DoublePendulumState& b) {
  double d = 0;
  for (int i = 0; i < 4; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

double first_departure(const std::vector<double>& times, const std::vector<DoublePendulumState>& a,
                       const std::vector<DoublePendulumState>& b, double threshold) {
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k)
    if (!(max_difference(a[k], b[k]) <= threshold)) return times[k];
  return std::numeric_limits<double>::infinity();
}

Line least_squares(const std::vector<double>& x, const std::vector<double>& y) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
  Line f;
  f.slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  f.intercept = (sy - f.slope * sx) / n;
  return f;
}

namespace {

// The range-space solve of docs/CONTRACT.md §2 in Real, with the multipliers μ (the forward_dynamics
// kernel keeps them to itself): the same steps as eom::Reference::forward_dynamics.
template <class Real>
bool closed_chain_solve(const std::array<Real, 10>& x, const std::array<Real, 26>& p,
                        std::array<Real, 5>& qdd, std::array<Real, 2>& mu) {
  using R = eom::Reference<eom::models::ClosedChain5, Real>;
  std::array<Real, 25> M;
  std::array<Real, 5> c, dV, Q, f;
  std::array<Real, 10> C;
  std::array<Real, 2> gamma;
  R::mass_matrix(x.data(), p.data(), M.data());
  R::coriolis(x.data(), x.data() + 5, p.data(), c.data());
  R::potential_gradient(x.data(), p.data(), dV.data());
  R::generalized_forces(Real(0.0), x.data(), x.data() + 5, nullptr, p.data(), Q.data());
  R::constraint_jacobian(x.data(), p.data(), C.data());
  R::constraint_bias(x.data(), x.data() + 5, p.data(), gamma.data());
  for (int i = 0; i < 5; ++i) f[i] = Q[i] - c[i] - dV[i];
  return eom::linalg::solve_constrained<Real, 5, 2>(M, f, C, gamma, qdd.data(), mu.data());
}

}  // namespace

DeadPointCase near_dead_point(double a) {
  auto p = ClosedChain::parameter_values;
  eom::StateOf<5> x{2 * a, -a, 1.5 * a, -0.7 * a, 0, 0, 0, 0, 0, 0};
  x[4] = -std::asin(std::sin(x[0]) + std::sin(x[1]) + std::sin(x[2]) + std::sin(x[3]));
  p[21] = 0;
  for (int i = 0; i < 5; ++i) p[21] += std::cos(x[i]);
  DeadPointCase c;
  c.a = a;
  std::array<double, 25> M;
  std::array<double, 10> C;
  ClosedChain::mass_matrix(x.data(), p.data(), M.data());
  ClosedChain::constraint_jacobian(x.data(), p.data(), C.data());
  const Eigen::Map<const Eigen::Matrix<double, 5, 5>> Mm(M.data());
  const Eigen::Map<const Eigen::Matrix<double, 2, 5>> Cm(C.data());
  const Eigen::Matrix2d S = Cm * Mm.llt().solve(Cm.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(S, Eigen::EigenvaluesOnly);
  c.schur_cond = es.eigenvalues().maxCoeff() / es.eigenvalues().minCoeff();
  const Eigen::Vector2d ds = S.diagonal().cwiseSqrt().cwiseInverse();
  es.compute(ds.asDiagonal() * S * ds.asDiagonal(), Eigen::EigenvaluesOnly);
  c.schur_scaled_cond = es.eigenvalues().maxCoeff() / es.eigenvalues().minCoeff();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>> em(Mm, Eigen::EigenvaluesOnly);
  c.mass_cond = em.eigenvalues().maxCoeff() / em.eigenvalues().minCoeff();

  std::array<double, 5> qdd, qdd_solve;
  std::array<double, 2> mu;
  c.ok = ClosedChain::forward_dynamics(0.0, x.data(), x.data() + 5, nullptr, p.data(), qdd.data());
  const bool ok_solve = closed_chain_solve<double>(x, p, qdd_solve, mu);
  std::array<dd_real, 10> xw;
  std::array<dd_real, 26> pw;
  std::array<dd_real, 5> qddw;
  std::array<dd_real, 2> muw;
  for (int i = 0; i < 10; ++i) xw[i] = dd_real(x[i]);
  for (int i = 0; i < 26; ++i) pw[i] = dd_real(p[i]);
  c.ok_wide = closed_chain_solve<dd_real>(xw, pw, qddw, muw);
  if (!c.ok) c.nan_on_failure = std::all_of(qdd.begin(), qdd.end(), [](double v) { return std::isnan(v); });
  if (c.ok && ok_solve && c.ok_wide) {
    double err = 0, size = 0, merr = 0, msize = 0;
    for (int i = 0; i < 5; ++i) {
      err = std::max(err, to_double(abs(dd_real(qdd[i]) - qddw[i])));
      size = std::max(size, to_double(abs(qddw[i])));
    }
    for (int i = 0; i < 2; ++i) {
      merr = std::max(merr, to_double(abs(dd_real(mu[i]) - muw[i])));
      msize = std::max(msize, to_double(abs(muw[i])));
    }
    c.qdd_error = err / size, c.qdd_norm = size;
    c.mu_error = merr / msize, c.mu_norm = msize;
  }
  return c;
}

std::vector<DeadPointStop> dead_point_stops() {
  auto p = ClosedChain::parameter_values;
  p[21] = 5.0;
  const eom::StateOf<5> straight{};
  std::vector<DeadPointStop> out;
  for (auto m : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::radau5,
                 eom::Method::taylor, eom::Method::variational}) {
    eom::IntegrationOptions opt;
    opt.method = m;
    opt.step = 1e-3;
    const auto r = eom::integrate<ClosedChain>(0.0, 1.0, straight, nullptr, p.data(), opt);
    out.push_back({m, r.status, r.t, all_finite(r.x)});
  }
  return out;
}

}  // namespace hard_cases
