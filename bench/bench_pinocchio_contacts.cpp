// eomgen's generated contact kernels (docs/CONTRACT.md §3, CONTACTS) against Pinocchio's rigid
// contact algorithms and Pinocchio's CppADCodeGen output of them, side by side in one binary.
// Opt-in: built only when EOM_BENCH_PINOCCHIO_PREFIX names a Pinocchio + CppADCodeGen install
// (bench/pinocchio.cmake; bench/pinocchio_install.sh builds one). bench/pinocchio_contacts.py runs
// it and writes docs/benchmarks/pinocchio_contacts.md.
//
// Robots, each on a free base, the Pinocchio model built from what eomgen read
// (bench/pinocchio_model.hpp), so that both sides integrate the same numbers:
//   - Solo12 (models/robots/solo12.urdf, eomgen's URDF reader: eombench::urdf_pinocchio_model),
//     point feet: stance (the four feet, 12 rows) and trot (FL_FOOT, HR_FOOT, 6 rows);
//   - MuJoCo's humanoid (humanoid.xml, 27 dof, eomgen-mjcf's tree-form header:
//     eombench::tree_pinocchio_model), flat feet held in placement (6d): double (left_foot,
//     right_foot, 12 rows) and single (right_foot, 6 rows). Its generalized forces are MuJoCo's
//     (gear · ctrl, joint springs and dampers): Pinocchio's τ is the model's Q(q, v, u), and Q's
//     Jacobians enter Pinocchio's derivatives by the chain rule (Robot below).
// eomgen's kernels have every parameter folded (FIXED_PARAMETERS ALL). Pinocchio's contacts:
// RigidConstraintModel CONTACT_3D (point) or CONTACT_6D at each foot, LOCAL_WORLD_ALIGNED,
// initConstraintDynamics once per set, ProximalSettings' defaults (mu = 0, one iteration: the
// exact KKT solve); eomgen: kd = 0, rho = 0; restitution 0 for the impulse.
//
// Kernels (eomgen's name: Pinocchio's algorithm; its generated code):
//   contact_dynamics              constraintDynamics; CodeGenConstraintDynamics
//   contact_dynamics_derivatives  constraintDynamics + computeConstraintDynamicsDerivatives
//                                 (Pinocchio's derivatives need the forward pass first);
//                                 CodeGenConstraintDynamicsDerivatives (both in one function)
//   impulse_dynamics              impulseDynamics (Pinocchio 3.7 generates no impulse code)
//   impulse_dynamics_derivatives  impulseDynamics + computeImpulseDynamicsDerivatives
//
// Conventions. eomgen: q = (x, quaternion w x y z, joints), v = (base velocity in world axes,
// angular velocity in base axes, joint rates), ∂/∂q along (δx world, δθ base axes, δjoints).
// Pinocchio: q = (x, quaternion x y z w, joints), v = (base velocity in base axes, the same
// angular velocity, joint rates), ∂/∂q along its integrate() (δx in base axes to first order).
// With R the base's rotation, v_pin = P v (P = diag(Rᵀ, I)), v̇ = Q a_pin + (R (ω × v_lin,pin); 0)
// (Q = diag(R, I)), v⁺ = Q v⁺_pin; λ and the impulse are in world axes on both sides. The
// derivatives are carried over by the chain rule (to_eomgen_* below). Pinocchio's impulse
// derivative ∂v⁺/∂v⁻ is that of v⁺ − v⁻ (computeImpulseDynamicsDerivatives: M⁻¹Jᵀ ∂Λ/∂v⁻): the
// identity is added.
//
// A 6d contact's drift differs: eomgen's bias is the frame origin's classical acceleration,
// Pinocchio's (CONTACT_6D) its spatial one, apart by ω × ẋ of the foot. The contact kernels of a
// set with a 6d contact are therefore compared and timed at states where the set's feet are at
// rest (v projected onto J's null space, as a held foot is), where the two coincide, their
// derivatives included (ω × ẋ is bilinear in two vanishing velocities); the impulse kernels on the
// unprojected states (at rest the impulse would vanish).
//
// Agreement first: on 16 random states, every output of eomgen's kernels and of Pinocchio's
// generated code against Pinocchio's algorithms, per output (v̇, λ, each derivative block),
// max-abs difference over max(1, max-abs of Pinocchio's). Above 1e-10 nothing is timed.
// Then timing: eombench::compare (alternating rounds, the median of the per-round ratios), the
// peers' inputs precomputed per state in their conventions and their raw outputs timed (no
// conversion), eomgen's kernels called as a user calls them.
#include <pinocchio/algorithm/constrained-dynamics-derivatives.hpp>
#include <pinocchio/algorithm/constrained-dynamics.hpp>
#include <pinocchio/algorithm/contact-info.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/impulse-dynamics-derivatives.hpp>
#include <pinocchio/algorithm/impulse-dynamics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/proximal.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <eomgen/urdf.hpp>

#include <pin_solo12_contacts.hpp>
#ifdef EOM_PIN_HUMANOID
#include <pin_humanoid_contacts.hpp>
#include <pin_humanoid_contacts_model.hpp>
#endif

#include <kernel_error.hpp>

#include "paired_timing.hpp"
#include "pinocchio_codegen.hpp"
#include "pinocchio_model.hpp"

namespace {

using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;
constexpr int kPool = 64;  // states cycled through by the timed calls (a power of two)
constexpr int kAgreementStates = 16;
constexpr double kAgreement = 1e-10;
constexpr double kRestitution = 0.0;

using ContactDatas = std::vector<pinocchio::RigidConstraintData,
                                 Eigen::aligned_allocator<pinocchio::RigidConstraintData>>;

Matrix3d skew(const Vector3d& a) {
  Matrix3d s;
  s << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return s;
}

// ---- robots and states ------------------------------------------------------------------------

struct State {
  VectorXd q, v, u;       // eomgen's
  Matrix3d R;             // the base's rotation
  VectorXd pq, pv, ptau;  // Pinocchio's q, v, τ
  VectorXd x;             // [pq; pv; ptau]: the generated peer's input
};

// What differs between the robots. Pinocchio's τ is eomgen's generalized force Q(q, v, u); Q is
// affine here (gear · u, springs, dampers), its Jacobians constant: ∂Q/∂u = B, ∂Q/∂q = Kq (along
// eomgen's tangent directions), ∂Q/∂v = Kv.
struct Robot {
  std::string name;
  pinocchio::Model model;
  std::function<VectorXd(const VectorXd& q, const VectorXd& v, const VectorXd& u)> tau;
  MatrixXd B, Kq, Kv;
  double u_range = 1.0;  // inputs drawn in ±u_range
};

// Pinocchio's side of a state.
void complete(const Robot& robot, State& s) {
  const Eigen::Index nq = s.q.size(), nv = s.v.size();
  s.R = Eigen::Quaterniond(s.q[3], s.q[4], s.q[5], s.q[6]).toRotationMatrix();
  s.pq.resize(nq), s.pv.resize(nv);
  s.pq << s.q.head<3>(), s.q[4], s.q[5], s.q[6], s.q[3], s.q.tail(nq - 7);
  s.pv << s.R.transpose() * s.v.head<3>(), s.v.tail(nv - 3);
  s.ptau = robot.tau(s.q, s.v, s.u);
  s.x.resize(nq + 2 * nv);
  s.x << s.pq, s.pv, s.ptau;
}

std::vector<State> random_states(const Robot& robot, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  const auto& m = robot.model;
  std::vector<State> pool(kPool);
  for (State& s : pool) {
    s.q.resize(m.nq), s.v.resize(m.nv), s.u.resize(robot.B.cols());
    for (double& x : s.q) x = d(rng);
    s.q.segment<4>(3).normalize();
    for (double& x : s.v) x = 2 * d(rng);
    for (double& x : s.u) x = robot.u_range * d(rng);
    complete(robot, s);
  }
  return pool;
}

// The states with the frames' velocities removed (v minus its least-squares part in J's range).
std::vector<State> at_rest(const Robot& robot, std::vector<State> pool,
                           const std::vector<pinocchio::FrameIndex>& frames) {
  const auto& m = robot.model;
  pinocchio::Data data(m);
  for (State& s : pool) {
    pinocchio::computeJointJacobians(m, data, s.pq);
    pinocchio::updateFramePlacements(m, data);
    MatrixXd J(6 * static_cast<Eigen::Index>(frames.size()), m.nv), Jf(6, m.nv);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      Jf.setZero();
      pinocchio::getFrameJacobian(m, data, frames[f], pinocchio::LOCAL_WORLD_ALIGNED, Jf);
      J.middleRows<6>(6 * static_cast<Eigen::Index>(f)) = Jf;
    }
    J.leftCols<3>() = J.leftCols<3>() * s.R.transpose();  // along eomgen's v (v_pin = P v)
    s.v -= J.transpose() * (J * J.transpose()).ldlt().solve(J * s.v);
    complete(robot, s);
  }
  return pool;
}

// ---- Pinocchio's outputs in eomgen's conventions (see the head of the file) -------------------

MatrixXd P(const State& s) {  // v_pin = P v; δ_pin = P δ
  MatrixXd p = MatrixXd::Identity(s.v.size(), s.v.size());
  p.topLeftCorner<3, 3>() = s.R.transpose();
  return p;
}
MatrixXd Q(const State& s) {  // velocities and accelerations from Pinocchio's base axes
  MatrixXd m = MatrixXd::Identity(s.v.size(), s.v.size());
  m.topLeftCorner<3, 3>() = s.R;
  return m;
}
MatrixXd dv_pin(const State& s) {  // ∂v_pin/∂δ at fixed v: v_lin,pin = Rᵀ v_lin turns with δθ
  MatrixXd m = MatrixXd::Zero(s.v.size(), s.v.size());
  m.block<3, 3>(0, 3) = skew(s.pv.head<3>());
  return m;
}

struct ContactOut {  // eomgen's outputs of contact_dynamics(_derivatives), column-major
  VectorXd vdot, lambda;
  MatrixXd vdot_q, vdot_v, vdot_u, lambda_q, lambda_v, lambda_u;
};
struct ImpulseOut {
  VectorXd v_plus, impulse;
  MatrixXd v_plus_q, v_plus_v, impulse_q, impulse_v;
};

// a, λ and (when Fq is not empty) the derivatives ∂a/∂q, ∂a/∂v, ∂a/∂τ, ∂λ/∂q, ∂λ/∂v, ∂λ/∂τ; τ's
// own dependence on q, v and u by the robot's Kq, Kv, B.
ContactOut to_eomgen_contact(const Robot& r, const State& s, const VectorXd& a,
                             const VectorXd& lambda, const MatrixXd& Fq, const MatrixXd& Fv,
                             const MatrixXd& Ft, const MatrixXd& Lq, const MatrixXd& Lv,
                             const MatrixXd& Lt) {
  ContactOut o;
  const Vector3d vl = s.pv.head<3>(), w = s.pv.segment<3>(3), al = a.head<3>();
  o.vdot = Q(s) * a;
  o.vdot.head<3>() += s.R * w.cross(vl);
  o.lambda = lambda;
  if (Fq.size() == 0) return o;
  const MatrixXd p = P(s), dv = dv_pin(s), q = Q(s);
  MatrixXd Hv = MatrixXd::Zero(s.v.size(), s.v.size());  // ∂(R (ω × v_lin))/∂v_pin
  Hv.block<3, 3>(0, 0) = s.R * skew(w);
  Hv.block<3, 3>(0, 3) = -s.R * skew(vl);
  o.vdot_q = q * (Fq * p + Fv * dv + Ft * r.Kq) + Hv * dv;
  o.vdot_q.block<3, 3>(0, 3) += -s.R * skew(al) - s.R * skew(w.cross(vl));
  o.vdot_v = (q * Fv + Hv) * p + q * Ft * r.Kv;
  o.vdot_u = q * Ft * r.B;
  o.lambda_q = Lq * p + Lv * dv + Lt * r.Kq;
  o.lambda_v = Lv * p + Lt * r.Kv;
  o.lambda_u = Lt * r.B;
  return o;
}

// v⁺, Λ and (when Gq is not empty) ∂v⁺/∂q, ∂(v⁺ − v⁻)/∂v⁻, ∂Λ/∂q, ∂Λ/∂v⁻.
ImpulseOut to_eomgen_impulse(const State& s, const VectorXd& v_plus, const VectorXd& impulse,
                             const MatrixXd& Gq, const MatrixXd& Gv, const MatrixXd& Iq,
                             const MatrixXd& Iv) {
  ImpulseOut o;
  o.v_plus = Q(s) * v_plus;
  o.impulse = impulse;
  if (Gq.size() == 0) return o;
  const MatrixXd p = P(s), dv = dv_pin(s), q = Q(s);
  const MatrixXd G = Gv + MatrixXd::Identity(s.v.size(), s.v.size());
  o.v_plus_q = q * (Gq * p + G * dv);
  o.v_plus_q.block<3, 3>(0, 3) += -s.R * skew(v_plus.head<3>());
  o.v_plus_v = q * G * p;
  o.impulse_q = Iq * p + Iv * dv;
  o.impulse_v = Iv * p;
  return o;
}

MatrixXd row_major(const double* x, int rows, int cols) {
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      x, rows, cols);
}
VectorXd vec(const double* x, int n) { return Eigen::Map<const VectorXd>(x, n); }
MatrixXd col_major(const double* x, int rows, int cols) {
  return Eigen::Map<const MatrixXd>(x, rows, cols);
}

// max-abs difference over max(1, max-abs reference), NaN infinitely wrong; sizes must agree.
double error(const MatrixXd& got, const MatrixXd& expected) {
  if (got.rows() != expected.rows() || got.cols() != expected.cols()) return INFINITY;
  return eomtest::kernel_error(got.data(), expected.data(), static_cast<int>(expected.size()));
}

// ---- the benchmark ----------------------------------------------------------------------------

const char* const kKernels[] = {"contact_dynamics", "contact_dynamics_derivatives",
                                "impulse_dynamics", "impulse_dynamics_derivatives"};

template <class K> void run(Robot& robot) {
  constexpr int nv = K::nv, nu = K::nu, nsets = K::ncontact_sets;
  static_assert(K::np == 0);
  const pinocchio::Model& model = robot.model;
  if (model.nq != K::nq || model.nv != nv || robot.B.cols() != nu)
    throw std::runtime_error(robot.name + ": Pinocchio's model has other sizes than eomgen's");
  for (std::size_t j = 2; j < model.names.size(); ++j)  // after the universe and the free joint
    if (model.names[j] != K::coordinate_names[static_cast<std::size_t>(model.idx_qs[j])])
      throw std::runtime_error(robot.name + ": coordinate " + std::to_string(model.idx_qs[j]) +
                               " is " + model.names[j] + " in Pinocchio's order");

  // Per set: Pinocchio's contacts, its data (initConstraintDynamics), its generated code.
  std::vector<eombench::PinocchioContacts> contacts(nsets);
  std::vector<ContactDatas> cdatas(nsets);
  std::vector<std::unique_ptr<pinocchio::Data>> datas;
  std::vector<pinocchio::ProximalSettings> settings(nsets);  // mu = 0, max_iter = 1
  using Algorithm = eombench::PinocchioGenerated::Algorithm;
  std::vector<std::unique_ptr<eombench::PinocchioGenerated>> cg_dyn, cg_der;
  std::vector<std::vector<pinocchio::FrameIndex>> held(nsets);  // a 6d set's frames, else none
  for (int s = 0; s < nsets; ++s) {
    bool any_six_d = false;
    for (int c = K::contact_begin[s]; c < K::contact_begin[s + 1]; ++c) {
      const std::string frame(K::frame_names[static_cast<std::size_t>(K::contact_frames[c])]);
      if (!model.existFrame(frame)) throw std::runtime_error(robot.name + ": no frame " + frame);
      const pinocchio::FrameIndex id = model.getFrameId(frame);
      const pinocchio::Frame& f = model.frames[id];
      contacts[s].emplace_back(K::contact_six_d[c] ? pinocchio::CONTACT_6D : pinocchio::CONTACT_3D,
                               model, f.parentJoint, f.placement, pinocchio::LOCAL_WORLD_ALIGNED);
      held[s].push_back(id);
      any_six_d = any_six_d || K::contact_six_d[c];
    }
    if (!any_six_d) held[s].clear();
    for (const auto& c : contacts[s]) cdatas[s].emplace_back(c);
    datas.push_back(std::make_unique<pinocchio::Data>(model));
    pinocchio::initConstraintDynamics(model, *datas.back(), contacts[s]);
    const std::string name = robot.name + "_" + std::string(K::contact_set_names[s]);
    std::printf("%s: generating Pinocchio's code (cached in the working directory)\n", name.c_str());
    std::fflush(stdout);
    cg_dyn.push_back(std::make_unique<eombench::PinocchioGenerated>(
        Algorithm::constraint_dynamics, model, contacts[s], name + "_constraint_dynamics",
        EOM_PINOCCHIO_CC));
    cg_der.push_back(std::make_unique<eombench::PinocchioGenerated>(
        Algorithm::constraint_dynamics_derivatives, model, contacts[s],
        name + "_constraint_dynamics_derivatives", EOM_PINOCCHIO_CC));
  }
  const std::vector<State> pool = random_states(robot, 11);

  for (int s = 0; s < nsets; ++s) {
    const int nc = K::contact_rows[s];
    // the contact kernels' states: a 6d set's feet at rest (see the head of the file)
    const std::vector<State> rest =
        held[static_cast<std::size_t>(s)].empty() ? pool
                                                   : at_rest(robot, pool, held[static_cast<std::size_t>(s)]);
    const std::string set(K::contact_set_names[s]);
    pinocchio::Data& data = *datas[static_cast<std::size_t>(s)];
    auto& cm = contacts[static_cast<std::size_t>(s)];
    auto& cd = cdatas[static_cast<std::size_t>(s)];
    auto& ps = settings[static_cast<std::size_t>(s)];
    auto& gd = *cg_dyn[static_cast<std::size_t>(s)];
    auto& gdd = *cg_der[static_cast<std::size_t>(s)];
    const MatrixXd none;

    // Agreement: [kernel][route: eomgen, codegen] the worst over states and outputs; and the
    // largest output of each kernel (Pinocchio's), for scale.
    double worst[4][2] = {}, largest[4] = {};
    std::map<std::string, std::array<double, 2>> detail;  // per output
    bool ok = true;
    for (int k = 0; k < kAgreementStates; ++k) {
      const State& x = rest[static_cast<std::size_t>(k)];
      const State& xi = pool[static_cast<std::size_t>(k)];  // the impulse's
      // eomgen
      ContactOut e;
      e.vdot.resize(nv), e.lambda.resize(nc);
      e.vdot_q.resize(nv, nv), e.vdot_v.resize(nv, nv), e.vdot_u.resize(nv, nu);
      e.lambda_q.resize(nc, nv), e.lambda_v.resize(nc, nv), e.lambda_u.resize(nc, nu);
      ok &= K::contact_dynamics(s, 0.0, x.q.data(), x.v.data(), x.u.data(), nullptr, 0.0, 0.0,
                                e.vdot.data(), e.lambda.data());
      ok &= K::contact_dynamics_derivatives(s, 0.0, x.q.data(), x.v.data(), x.u.data(), nullptr,
                                            0.0, 0.0, e.vdot_q.data(), e.vdot_v.data(),
                                            e.vdot_u.data(), e.lambda_q.data(), e.lambda_v.data(),
                                            e.lambda_u.data());
      ImpulseOut ei;
      ei.v_plus.resize(nv), ei.impulse.resize(nc);
      ei.v_plus_q.resize(nv, nv), ei.v_plus_v.resize(nv, nv);
      ei.impulse_q.resize(nc, nv), ei.impulse_v.resize(nc, nv);
      ok &= K::impulse_dynamics(s, xi.q.data(), xi.v.data(), nullptr, kRestitution, 0.0,
                                ei.v_plus.data(), ei.impulse.data());
      ok &= K::impulse_dynamics_derivatives(s, xi.q.data(), xi.v.data(), nullptr, kRestitution, 0.0,
                                            ei.v_plus_q.data(), ei.v_plus_v.data(),
                                            ei.impulse_q.data(), ei.impulse_v.data());
      // Pinocchio
      pinocchio::constraintDynamics(model, data, x.pq, x.pv, x.ptau, cm, cd, ps);
      pinocchio::computeConstraintDynamicsDerivatives(model, data, cm, cd, ps);
      const ContactOut p = to_eomgen_contact(robot, x, data.ddq, data.lambda_c, data.ddq_dq, data.ddq_dv,
                                             data.ddq_dtau, data.dlambda_dq, data.dlambda_dv,
                                             data.dlambda_dtau);
      pinocchio::impulseDynamics(model, data, xi.pq, xi.pv, cm, cd, kRestitution, ps);
      const VectorXd v_plus = data.dq_after, impulse = data.impulse_c;
      pinocchio::computeImpulseDynamicsDerivatives(model, data, cm, cd, kRestitution, ps);
      const ImpulseOut pi = to_eomgen_impulse(xi, v_plus, impulse, data.ddq_dq, data.ddq_dv,
                                              data.dlambda_dq, data.dlambda_dv);
      // Pinocchio's generated code
      gd(x.x.data());
      const ContactOut g = to_eomgen_contact(robot, x, vec(gd.out(), nv), vec(gd.out() + nv, nc), none,
                                             none, none, none, none, none);
      gdd(x.x.data());
      const double* o = gdd.out();
      const int NN = nv * nv, CN = nc * nv;
      // (the derivative code returns derivatives only; their conversion also needs a, here the
      // generated constraint_dynamics')
      const ContactOut gg = to_eomgen_contact(
          robot, x, vec(gd.out(), nv), vec(gd.out() + nv, nc), row_major(o, nv, nv),
          row_major(o + NN, nv, nv), row_major(o + 2 * NN, nv, nv), col_major(o + 3 * NN, nc, nv),
          col_major(o + 3 * NN + CN, nc, nv), col_major(o + 3 * NN + 2 * CN, nc, nv));
      // [route: eomgen, codegen] per output; -1: no such route
      auto note = [&](int kernel, const char* output, double eomgen, double codegen) {
        auto& w = detail[std::string(kKernels[kernel]) + " " + output];
        w[0] = std::max(w[0], eomgen);
        w[1] = codegen < 0 ? -1 : std::max(w[1], codegen);
        for (int r = 0; r < 2; ++r)
          worst[kernel][r] = w[r] < 0 ? -1 : std::max(worst[kernel][r], w[r]);
      };
      note(0, "vdot", error(e.vdot, p.vdot), error(g.vdot, p.vdot));
      note(0, "lambda", error(e.lambda, p.lambda), error(g.lambda, p.lambda));
      note(1, "dvdot_dq", error(e.vdot_q, p.vdot_q), error(gg.vdot_q, p.vdot_q));
      note(1, "dvdot_dv", error(e.vdot_v, p.vdot_v), error(gg.vdot_v, p.vdot_v));
      note(1, "dvdot_du", error(e.vdot_u, p.vdot_u), error(gg.vdot_u, p.vdot_u));
      note(1, "dlambda_dq", error(e.lambda_q, p.lambda_q), error(gg.lambda_q, p.lambda_q));
      note(1, "dlambda_dv", error(e.lambda_v, p.lambda_v), error(gg.lambda_v, p.lambda_v));
      note(1, "dlambda_du", error(e.lambda_u, p.lambda_u), error(gg.lambda_u, p.lambda_u));
      note(2, "v_plus", error(ei.v_plus, pi.v_plus), -1);
      note(2, "impulse", error(ei.impulse, pi.impulse), -1);
      note(3, "dvplus_dq", error(ei.v_plus_q, pi.v_plus_q), -1);
      note(3, "dvplus_dv", error(ei.v_plus_v, pi.v_plus_v), -1);
      note(3, "dimpulse_dq", error(ei.impulse_q, pi.impulse_q), -1);
      note(3, "dimpulse_dv", error(ei.impulse_v, pi.impulse_v), -1);
      const double big[4] = {
          std::max(p.vdot.cwiseAbs().maxCoeff(), p.lambda.cwiseAbs().maxCoeff()),
          std::max({p.vdot_q.cwiseAbs().maxCoeff(), p.vdot_v.cwiseAbs().maxCoeff(),
                    p.lambda_q.cwiseAbs().maxCoeff(), p.lambda_v.cwiseAbs().maxCoeff()}),
          std::max(pi.v_plus.cwiseAbs().maxCoeff(), pi.impulse.cwiseAbs().maxCoeff()),
          std::max({pi.v_plus_q.cwiseAbs().maxCoeff(), pi.v_plus_v.cwiseAbs().maxCoeff(),
                    pi.impulse_q.cwiseAbs().maxCoeff(), pi.impulse_v.cwiseAbs().maxCoeff()})};
      for (int kernel = 0; kernel < 4; ++kernel)
        largest[kernel] = std::max(largest[kernel], big[kernel]);
    }
    for (const auto& [output, w] : detail) {
      std::printf("output %-6s %-42s eomgen=%.1e", set.c_str(), output.c_str(), w[0]);
      if (w[1] >= 0) std::printf(" codegen=%.1e", w[1]);
      std::printf("\n");
    }
    if (!ok) {
      std::fprintf(stderr, "bench_pinocchio_contacts: %s: an eomgen kernel returned false\n",
                   set.c_str());
      std::abort();
    }
    bool agree = true;
    for (int kernel = 0; kernel < 4; ++kernel) {
      std::printf("agreement %-6s %-29s eomgen=%.1e", set.c_str(), kKernels[kernel],
                  worst[kernel][0]);
      agree = agree && worst[kernel][0] <= kAgreement;
      if (worst[kernel][1] >= 0) {
        std::printf(" codegen=%.1e", worst[kernel][1]);
        agree = agree && worst[kernel][1] <= kAgreement;
      }
      std::printf(" largest=%.1e\n", largest[kernel]);
    }
    std::fflush(stdout);
    if (!agree) {
      std::fprintf(stderr, "bench_pinocchio_contacts: %s: a route differs from Pinocchio by more "
                           "than %.0e: nothing is timed\n", set.c_str(), kAgreement);
      std::abort();
    }

    // Timing.
    std::vector<double> y(static_cast<std::size_t>(6 * nv * nv), 0.0);
    double* b[6];
    for (int i = 0; i < 6; ++i) b[i] = y.data() + i * nv * nv;
    auto sink = [](double x) { eombench::sink = x; };
    for (int kernel = 0; kernel < 4; ++kernel) {
      const std::vector<State>& states = kernel < 2 ? rest : pool;
      auto at = [&states](int i) -> const State& {
        return states[static_cast<std::size_t>(i & (kPool - 1))];
      };
      auto ours = [&, kernel](int i) {
        const State& x = at(i);
        switch (kernel) {
          case 0: K::contact_dynamics(s, 0.0, x.q.data(), x.v.data(), x.u.data(), nullptr, 0.0,
                                      0.0, b[0], b[1]); break;
          case 1: K::contact_dynamics_derivatives(s, 0.0, x.q.data(), x.v.data(), x.u.data(),
                                                  nullptr, 0.0, 0.0, b[0], b[1], b[2], b[3], b[4],
                                                  b[5]); break;
          case 2: K::impulse_dynamics(s, x.q.data(), x.v.data(), nullptr, kRestitution, 0.0, b[0],
                                      b[1]); break;
          default: K::impulse_dynamics_derivatives(s, x.q.data(), x.v.data(), nullptr,
                                                   kRestitution, 0.0, b[0], b[1], b[2], b[3]);
        }
        sink(y[0]);
      };
      auto generated = [&, kernel](int i) {
        const State& x = at(i);
        auto& f = kernel == 0 ? gd : gdd;
        f(x.x.data());
        sink(f.out()[0]);
      };
      auto pinocchio_ = [&, kernel](int i) {
        const State& x = at(i);
        switch (kernel) {
          case 0: pinocchio::constraintDynamics(model, data, x.pq, x.pv, x.ptau, cm, cd, ps);
                  sink(data.lambda_c[0]); break;
          case 1: pinocchio::constraintDynamics(model, data, x.pq, x.pv, x.ptau, cm, cd, ps);
                  pinocchio::computeConstraintDynamicsDerivatives(model, data, cm, cd, ps);
                  sink(data.dlambda_dq(0, 0)); break;
          case 2: pinocchio::impulseDynamics(model, data, x.pq, x.pv, cm, cd, kRestitution, ps);
                  sink(data.impulse_c[0]); break;
          default: pinocchio::impulseDynamics(model, data, x.pq, x.pv, cm, cd, kRestitution, ps);
                   pinocchio::computeImpulseDynamicsDerivatives(model, data, cm, cd, kRestitution,
                                                                ps);
                   sink(data.dlambda_dq(0, 0));
        }
      };
      const std::string what = set + "/" + kKernels[kernel];
      if (kernel < 2)
        eombench::compare((what + ": eomgen / Pinocchio codegen").c_str(), ours, generated);
      eombench::compare((what + ": eomgen / Pinocchio").c_str(), ours, pinocchio_);
      std::fflush(stdout);
    }
  }
}

// τ's Jacobians B, Kq, Kv by unit steps from q = (0, identity, 0), v = 0, u = 0: exact for an
// affine Q (the derivatives' agreement checks that it is). Q must not depend on the base's pose.
void linearize(Robot& r) {
  const auto& m = r.model;
  VectorXd q0 = VectorXd::Zero(m.nq), v0 = VectorXd::Zero(m.nv), u0 = VectorXd::Zero(r.B.cols());
  q0[3] = 1;
  const VectorXd t0 = r.tau(q0, v0, u0);
  r.Kq.setZero(m.nv, m.nv), r.Kv.setZero(m.nv, m.nv);
  for (Eigen::Index i = 0; i < m.nq; ++i) {
    VectorXd q = q0;
    q[i] += 1;
    const VectorXd d = r.tau(q, v0, u0) - t0;
    if (i >= 7) r.Kq.col(i - 1) = d;
    else if (d.cwiseAbs().maxCoeff() != 0)
      throw std::runtime_error(r.name + ": τ depends on the base's pose");
  }
  for (Eigen::Index i = 0; i < m.nv; ++i)
    r.Kv.col(i) = r.tau(q0, VectorXd::Unit(m.nv, i), u0) - t0;
  for (Eigen::Index i = 0; i < r.B.cols(); ++i)
    r.B.col(i) = r.tau(q0, v0, VectorXd::Unit(r.B.cols(), i)) - t0;
}

template <class K> std::vector<std::string> contact_frames() {
  std::vector<std::string> frames;
  for (int c = 0; c < K::ncontacts; ++c) {
    const std::string f(K::frame_names[static_cast<std::size_t>(K::contact_frames[c])]);
    if (std::find(frames.begin(), frames.end(), f) == frames.end()) frames.push_back(f);
  }
  return frames;
}

// Solo12: τ = (0, u); its URDF has no joint damping or friction (checked).
Robot solo12() {
  using K = pin_solo12_contacts::Kernels;
  const eom::urdf::Robot urdf = eom::urdf::read(EOM_SOLO12_URDF, true);
  for (const auto& joint : urdf.joints)
    if (joint.damping != 0 || joint.friction != 0)
      throw std::runtime_error("solo12.urdf: joint damping or friction: not handled here");
  Robot r{"solo12", eombench::urdf_pinocchio_model(urdf, contact_frames<K>()),
          [](const VectorXd&, const VectorXd& v, const VectorXd& u) {
            VectorXd tau = VectorXd::Zero(v.size());
            tau.tail(u.size()) = u;
            return tau;
          },
          MatrixXd(K::nv, K::nu), {}, {}, 3.0};
  linearize(r);
  return r;
}

#ifdef EOM_PIN_HUMANOID
// MuJoCo's humanoid: τ = the model's generalized forces (gear · ctrl, springs, dampers); its
// inputs drawn inside their ctrlrange ±1, where the clamp leaves them.
Robot humanoid() {
  using K = pin_humanoid_contacts::Kernels;
  using Model = eom::mjcf_models::pin_humanoid_contacts;
  Robot r{"humanoid", eombench::tree_pinocchio_model<Model>(contact_frames<K>()),
          [](const VectorXd& q, const VectorXd& v, const VectorXd& u) {
            VectorXd Q(v.size());
            Model::generalized_forces<double>(0.0, {q.data(), static_cast<std::size_t>(q.size())},
                                              {v.data(), static_cast<std::size_t>(v.size())},
                                              {u.data(), static_cast<std::size_t>(u.size())},
                                              Model::parameter_values,
                                              {Q.data(), static_cast<std::size_t>(Q.size())});
            return Q;
          },
          MatrixXd(K::nv, K::nu), {}, {}, 0.9};
  r.model.name = "humanoid";
  linearize(r);
  return r;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  // The generated peer's libraries live in (and are reused from) the working directory, or the
  // directory given as the first argument.
  if (argc > 1) {
    std::filesystem::create_directories(argv[1]);
    std::filesystem::current_path(argv[1]);
  }
  try {
    Robot quadruped = solo12();
    run<pin_solo12_contacts::Kernels>(quadruped);
#ifdef EOM_PIN_HUMANOID
    Robot biped = humanoid();
    run<pin_humanoid_contacts::Kernels>(biped);
#endif
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_pinocchio_contacts: %s\n", e.what());
    return 1;
  }
  return 0;
}
