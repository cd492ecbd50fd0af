// See pinocchio_truth.hpp. Compiled with -ffp-contract=off (bench/pinocchio.cmake).
#include "pinocchio_truth.hpp"

#include <qd/dd_real.h>

#include <recursive_dynamics.hpp>

namespace eombench {

using DD = std::vector<dd_real>;

struct PinocchioTruth::Model {
  eomtest::RecursiveDynamics<dd_real> rd;
};

PinocchioTruth::PinocchioTruth(const eom::urdf::Robot& robot)
    : model_(new Model{eomtest::RecursiveDynamics<dd_real>(robot)}) {}
PinocchioTruth::~PinocchioTruth() = default;
int PinocchioTruth::nv() const { return model_->rd.nv(); }
std::vector<double> PinocchioTruth::damping() const {
  std::vector<double> d;
  for (const dd_real& x : model_->rd.damping()) d.push_back(to_double(x));
  return d;
}

Truth PinocchioTruth::at(const double* q0, const double* v0, const double* u0, const double* a0) {
  auto& rd = model_->rd;
  const auto N = static_cast<std::size_t>(rd.nv());
  const auto& d = rd.damping();
  auto narrow = [](const DD& x) {
    std::vector<double> y(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) y[i] = to_double(x[i]);
    return y;
  };
  const DD q(q0, q0 + N), v(v0, v0 + N), u(u0, u0 + N), a(a0, a0 + N);
  DD M(N * N);
  rd.mass_matrix(q, M);
  auto fd = [&](const DD& q_, const DD& v_, const DD& u_) {
    DD r(N);
    rd.forward_dynamics(q_, v_, u_, r);
    return r;
  };
  auto id = [&](const DD& q_, const DD& v_) {  // τ = RNEA − Q = RNEA − u + d⊙v
    DD r(N);
    rd.inverse_dynamics(q_, v_, a, r);
    for (std::size_t i = 0; i < N; ++i) r[i] -= u[i] - d[i] * v_[i];
    return r;
  };
  Truth t;
  t.M = narrow(M);
  t.qdd = narrow(fd(q, v, u));
  t.tau = narrow(id(q, v));
  // Central differences: with h = 1e-10 the truncation (h²) and rounding (1e-32 / h) errors are
  // far below double's.
  const dd_real h(1e-10);
  auto column = [&](std::vector<double>& J, std::size_t j, const DD& plus, const DD& minus) {
    for (std::size_t i = 0; i < N; ++i) J[i + N * j] = to_double((plus[i] - minus[i]) / (2.0 * h));
  };
  for (auto* J : {&t.dqdd_dq, &t.dqdd_dv, &t.minv, &t.dtau_dq, &t.dtau_dv}) J->assign(N * N, 0.0);
  for (std::size_t j = 0; j < N; ++j) {
    DD qp = q, qm = q, vp = v, vm = v, up = u, um = u;
    qp[j] += h, qm[j] -= h, vp[j] += h, vm[j] -= h, up[j] += h, um[j] -= h;
    column(t.dqdd_dq, j, fd(qp, v, u), fd(qm, v, u));
    column(t.dqdd_dv, j, fd(q, vp, u), fd(q, vm, u));
    column(t.minv, j, fd(q, v, up), fd(q, v, um));
    column(t.dtau_dq, j, id(qp, v), id(qm, v));
    column(t.dtau_dv, j, id(q, vp), id(q, vm));
  }
  return t;
}

}  // namespace eombench
