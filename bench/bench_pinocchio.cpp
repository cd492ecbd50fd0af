// The codegen peer: eomgen's generated kernels against Pinocchio (its recursive algorithms in
// double) and Pinocchio's CppADCodeGen output (the same algorithms taped once, emitted as C,
// compiled with -O3 -march=native and called as raw C functions), side by side in one binary.
// Opt-in: built only when EOM_BENCH_PINOCCHIO_PREFIX names a Pinocchio + CppADCodeGen install
// (bench/pinocchio.cmake; bench/pinocchio.sh builds one from sources and runs this).
//
// Robots: the Panda, the UR5 (models/robots), the planar chain of EOM_BENCH_PINOCCHIO_CHAIN
// links (bench/robots/chain<N>.urdf), where MuJoCo and its samples are installed MuJoCo's
// humanoid on its free base, and Romeo on its free base (bundled, example-robot-data); the two
// free-base robots have their own conventions and reference (run_floating below). The arms, the
// chain and Romeo are read by eomgen's URDF reader; the Pinocchio
// model is built from what it read (pinocchio_model.hpp: moving joints depth first, fixed
// joints merged into their parent body, as Pinocchio's own URDF parser does), so both sides integrate the
// same numbers. Further arguments after the library directory name the robots to run. eomgen's kernels come twice: every parameter folded (FIXED_PARAMETERS ALL) and
// every parameter free (p passed at run time).
//
// Kernels (eomgen's name: Pinocchio's algorithm):
//   mass_matrix                   crba (Pinocchio fills the upper triangle only; not completed)
//   inverse_dynamics              rnea
//   forward_dynamics              aba
//   forward_dynamics_derivatives  computeABADerivatives (∂q̈/∂q, ∂q̈/∂v, M⁻¹)
//   inverse_dynamics_derivatives  computeRNEADerivatives (∂τ/∂q, ∂τ/∂v, and M, which eomgen's
//                                 kernel does not return)
// eomgen's kernels include the URDF's joint damping (Q = u − d⊙q̇); Pinocchio's get τ = u − d⊙q̇
// precomputed per state, and the packed input vector its generated code reads, also
// precomputed: the peer is spared that work.
//
// Accuracy first: on 16 random states every route is compared with Featherstone's algorithms in
// double-double (tests/support/recursive_dynamics.hpp, built from the same file; derivatives by
// central differences in double-double, error below 1e-20); max-abs error over max(1, max-abs
// reference). The run aborts when any route is off by more than 1e-8 (a model mismatch).
// Then timing: eombench::compare (alternating rounds, the median of the per-round ratios).
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea-derivatives.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <eomgen/urdf.hpp>

#include <pin_chain_folded.hpp>
#include <pin_chain_free.hpp>
#include <pin_panda_folded.hpp>
#include <pin_panda_free.hpp>
#include <pin_romeo_folded.hpp>
#include <pin_romeo_free.hpp>
#include <pin_ur5_folded.hpp>
#include <pin_ur5_free.hpp>
#ifdef EOM_PIN_HUMANOID
#include <pin_humanoid_folded.hpp>
#include <pin_humanoid_folded_model.hpp>
#include <pin_humanoid_free.hpp>
#endif

#include <kernel_error.hpp>

#include "paired_timing.hpp"
#include "pinocchio_codegen.hpp"
#include "pinocchio_model.hpp"
#include "pinocchio_truth.hpp"

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr int kPool = 64;          // states cycled through by the timed calls (a power of two)
constexpr int kAccuracyStates = 16;
constexpr double kAgreement = 1e-8;

// The generated outputs as column-major matrices: CodeGenCRBA writes M's upper triangle row by
// row; the derivative classes write their n×n blocks row-major, one after the other.
MatrixXd packed_upper(const double* x, int n) {
  MatrixXd m(n, n);
  for (int i = 0, k = 0; i < n; ++i)
    for (int j = i; j < n; ++j) m(i, j) = m(j, i) = x[k++];
  return m;
}
MatrixXd row_major(const double* x, int n) {
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      x, n, n);
}

// ---- states -----------------------------------------------------------------------------------

struct State {
  VectorXd q, v, u, a;  // a: q̈ for the inverse-dynamics kernels
  VectorXd tau;         // u − d⊙v: Pinocchio's joint torque for the forward dynamics
  VectorXd qva, qvtau;  // [q; v; a] and [q; v; tau]: the generated peer's packed inputs
};

std::vector<State> random_states(int n, const std::vector<double>& damping, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-2.0, 2.0), torque(-10.0, 10.0);
  std::vector<State> pool(kPool);
  for (State& s : pool) {
    s.q.resize(n), s.v.resize(n), s.u.resize(n), s.a.resize(n), s.tau.resize(n);
    for (int i = 0; i < n; ++i) {
      s.q[i] = angle(rng), s.v[i] = rate(rng), s.u[i] = torque(rng), s.a[i] = rate(rng);
      s.tau[i] = s.u[i] - damping[static_cast<std::size_t>(i)] * s.v[i];
    }
    s.qva.resize(3 * n), s.qvtau.resize(3 * n);
    s.qva << s.q, s.v, s.a;
    s.qvtau << s.q, s.v, s.tau;
  }
  return pool;
}

// ---- accuracy ---------------------------------------------------------------------------------

// The kernel tests' measure: max-abs error over max(1, max-abs reference), NaN infinitely wrong.
double error(const double* got, const std::vector<double>& expected) {
  return eomtest::kernel_error(got, expected.data(), static_cast<int>(expected.size()));
}

// M from Pinocchio's upper triangle.
MatrixXd symmetric(const MatrixXd& upper) {
  MatrixXd m = upper;
  m.triangularView<Eigen::StrictlyLower>() = m.transpose();
  return m;
}

// ---- Pinocchio's side, shared by the robots -------------------------------------------------

// The five generated algorithms of one model, their libraries named after `tag` (and cached in
// the working directory).
struct Generated {
  std::unique_ptr<eombench::PinocchioGenerated> crba, rnea, aba, daba, drnea;
};
Generated generate(const pinocchio::Model& model, const std::string& tag) {
  std::printf("%s: generating Pinocchio's code (cached in the working directory)\n", tag.c_str());
  std::fflush(stdout);
  using Algorithm = eombench::PinocchioGenerated::Algorithm;
  auto one = [&](Algorithm algorithm, const char* name) {
    return std::make_unique<eombench::PinocchioGenerated>(algorithm, model, tag + "_" + name,
                                                          EOM_PINOCCHIO_CC);
  };
  return {one(Algorithm::crba, "crba"), one(Algorithm::rnea, "rnea"), one(Algorithm::aba, "aba"),
          one(Algorithm::aba_derivatives, "aba_derivatives"),
          one(Algorithm::rnea_derivatives, "rnea_derivatives")};
}

// One state's inputs in Pinocchio's conventions: q, v, a (rnea), τ (aba) and the generated
// code's packed [q; v; a] and [q; v; τ].
struct PinocchioInputs {
  const VectorXd &q, &v, &a, &tau, &qva, &qvtau;
};

const char* const kKernels[] = {"mass_matrix", "inverse_dynamics", "forward_dynamics",
                                "forward_dynamics_derivatives", "inverse_dynamics_derivatives"};

// eomgen's kernel number `kernel` (kKernels' order) of K at a state's q, v, u and v̇ (a), its
// outputs into y (the derivative kernels' blocks nv² apart).
template <class K, class S>
const double* call_eomgen(int kernel, const double* p, const S& s, double* y) {
  constexpr std::size_t NN = static_cast<std::size_t>(K::nv) * K::nv;
  const double *q = s.q.data(), *v = s.v.data(), *u = s.u.data(), *a = s.a.data();
  switch (kernel) {
    case 0: K::mass_matrix(q, p, y); break;
    case 1: K::inverse_dynamics(0.0, q, v, a, u, p, y); break;
    case 2: K::forward_dynamics(0.0, q, v, u, p, y); break;
    case 3: K::forward_dynamics_derivatives(0.0, q, v, u, p, y, y + NN, y + 2 * NN); break;
    default: K::inverse_dynamics_derivatives(0.0, q, v, a, u, p, y, y + NN);
  }
  return y;
}

// Timing: each kernel's three pairs in alternating rounds (eombench::compare) on the pool's
// states. eomgen(kernels, p, kernel, state) calls eomgen's kernel (its raw outputs); inputs(state)
// gives Pinocchio's, whose raw outputs are timed (no conversion).
template <class Folded, class Free, class S, class Eomgen, class Inputs>
void time_kernels(const std::string& tag, const std::vector<S>& pool, Eomgen& eomgen,
                  Inputs inputs, Generated& cg, const pinocchio::Model& model,
                  pinocchio::Data& data, const double* p) {
  auto at = [&](int i) -> const S& { return pool[static_cast<std::size_t>(i & (kPool - 1))]; };
  auto sink = [](const double* x) { eombench::sink = x[0]; };
  for (int kernel = 0; kernel < 5; ++kernel) {
    auto gen = [&](auto kernels, const double* pp) {
      return [&, kernels, kernel, pp](int i) { sink(eomgen(kernels, pp, kernel, at(i))); };
    };
    auto peer = [&](int i) {
      const PinocchioInputs s = inputs(at(i));
      switch (kernel) {
        case 0: (*cg.crba)(s.q.data()); sink(cg.crba->out()); break;
        case 1: (*cg.rnea)(s.qva.data()); sink(cg.rnea->out()); break;
        case 2: (*cg.aba)(s.qvtau.data()); sink(cg.aba->out()); break;
        case 3: (*cg.daba)(s.qvtau.data()); sink(cg.daba->out()); break;
        default: (*cg.drnea)(s.qva.data()); sink(cg.drnea->out());
      }
    };
    auto recursive = [&](int i) {
      const PinocchioInputs s = inputs(at(i));
      switch (kernel) {
        case 0: pinocchio::crba(model, data, s.q); sink(data.M.data()); break;
        case 1: pinocchio::rnea(model, data, s.q, s.v, s.a); sink(data.tau.data()); break;
        case 2: pinocchio::aba(model, data, s.q, s.v, s.tau); sink(data.ddq.data()); break;
        case 3: pinocchio::computeABADerivatives(model, data, s.q, s.v, s.tau);
                sink(data.ddq_dq.data()); break;
        default: pinocchio::computeRNEADerivatives(model, data, s.q, s.v, s.a);
                 sink(data.dtau_dq.data());
      }
    };
    const std::string what = tag + "/" + kKernels[kernel];
    eombench::compare((what + ": folded / Pinocchio codegen").c_str(), gen(Folded{}, nullptr), peer);
    eombench::compare((what + ": free / Pinocchio codegen").c_str(), gen(Free{}, p), peer);
    eombench::compare((what + ": folded / Pinocchio").c_str(), gen(Folded{}, nullptr), recursive);
    std::fflush(stdout);
  }
}

// ---- one robot --------------------------------------------------------------------------------

const char* const kRoutes[] = {"folded", "free", "codegen", "pinocchio"};  // in the printed lines

// Prints a robot's accuracy lines (each kernel's worst error on each of the first R routes) and
// aborts when one is above kAgreement: a model (or convention) mismatch, nothing worth timing.
template <std::size_t R> void check_accuracy(const char* robot, const double (&worst)[5][R]) {
  bool agree = true;
  for (int kernel = 0; kernel < 5; ++kernel) {
    std::printf("accuracy %-6s %-29s", robot, kKernels[kernel]);
    for (std::size_t r = 0; r < R; ++r) {
      std::printf("  %s=%.1e", kRoutes[r], worst[kernel][r]);
      agree = agree && worst[kernel][r] <= kAgreement;
    }
    std::printf("\n");
  }
  std::fflush(stdout);
  if (!agree) {
    std::fprintf(stderr, "bench_pinocchio: %s: a route is off by more than %.0e: a model or "
                         "convention mismatch; nothing is timed\n", robot, kAgreement);
    std::abort();
  }
}

template <class Folded, class Free> void run_robot(const char* robot, const std::string& urdf) {
  constexpr int n = Folded::nq;
  constexpr std::size_t N = n, NN = N * N;
  static_assert(Folded::np == 0 && Free::nq == n && Folded::nu == n);
  const eom::urdf::Robot parsed = eom::urdf::read(urdf);
  const pinocchio::Model model = eombench::urdf_pinocchio_model(parsed);
  pinocchio::Data data(model);
  eombench::PinocchioTruth truth(parsed);
  if (model.nq != n || truth.nv() != n) {
    std::fprintf(stderr, "bench_pinocchio: %s: %d Pinocchio coordinates, %d generated\n", robot,
                 model.nq, n);
    std::abort();
  }
  for (int i = 0; i < n; ++i)
    if (model.names[static_cast<std::size_t>(i) + 1] != Folded::coordinate_names[i]) {
      std::fprintf(stderr, "bench_pinocchio: %s: coordinate %d is %s in Pinocchio's order\n",
                   robot, i, model.names[static_cast<std::size_t>(i) + 1].c_str());
      std::abort();
    }
  const std::vector<double> damping = truth.damping();
  const std::vector<State> pool = random_states(n, damping, 7);
  const double* p = Free::parameter_values.data();

  const std::string tag = robot;
  Generated cg = generate(model, tag);
  auto &cg_crba = *cg.crba, &cg_rnea = *cg.rnea, &cg_aba = *cg.aba, &cg_daba = *cg.daba,
       &cg_drnea = *cg.drnea;

  // Every route's outputs, in eomgen's conventions, for one state and kernel.
  std::array<double, 3 * NN> y{};
  auto eomgen = [&](auto kernels, const double* pp, int kernel, const State& s) -> const double* {
    return call_eomgen<decltype(kernels)>(kernel, pp, s, y.data());
  };
  // Pinocchio's outputs (generated or not, as column-major matrices; M and M⁻¹ with their upper
  // triangles right) turned into eomgen's: the damping, the inputs, both triangles.
  const Eigen::Map<const VectorXd> d(damping.data(), n);
  auto from_pinocchio = [&](int kernel, const State& s, const MatrixXd& m1, const MatrixXd& m2,
                            const MatrixXd& m3) -> const double* {
    Eigen::Map<MatrixXd> y0(y.data(), n, kernel == 1 || kernel == 2 ? 1 : n);
    Eigen::Map<MatrixXd> y1(y.data() + NN, n, n), y2(y.data() + 2 * NN, n, n);
    switch (kernel) {
      case 0: y0 = symmetric(m1); break;
      case 1: y0 = m1 - s.u + d.cwiseProduct(s.v); break;  // τ = RNEA − Q
      case 2: y0 = m1; break;
      case 3:  // ∂q̈/∂q̇ at fixed u = ∂q̈/∂v at fixed τ − M⁻¹ diag(d)
        y0 = m1;
        y2 = symmetric(m3);
        y1 = m2 - y2 * d.asDiagonal();
        break;
      default:
        y0 = m1;
        y1 = m2;
        y1.diagonal() += d;
    }
    return y.data();
  };
  const MatrixXd none;
  auto codegen = [&](int kernel, const State& s) -> const double* {
    switch (kernel) {
      case 0: cg_crba(s.q.data()); return from_pinocchio(0, s, packed_upper(cg_crba.out(), n), none, none);
      case 1:
        cg_rnea(s.qva.data());
        return from_pinocchio(1, s, Eigen::Map<const VectorXd>(cg_rnea.out(), n), none, none);
      case 2:
        cg_aba(s.qvtau.data());
        return from_pinocchio(2, s, Eigen::Map<const VectorXd>(cg_aba.out(), n), none, none);
      case 3: {
        cg_daba(s.qvtau.data());
        const double* o = cg_daba.out();
        return from_pinocchio(3, s, row_major(o, n), row_major(o + NN, n), row_major(o + 2 * NN, n));
      }
      default: {
        cg_drnea(s.qva.data());
        const double* o = cg_drnea.out();
        return from_pinocchio(4, s, row_major(o, n), row_major(o + NN, n), none);
      }
    }
  };
  auto plain = [&](int kernel, const State& s) -> const double* {
    switch (kernel) {
      case 0: pinocchio::crba(model, data, s.q); return from_pinocchio(0, s, data.M, none, none);
      case 1: pinocchio::rnea(model, data, s.q, s.v, s.a); return from_pinocchio(1, s, data.tau, none, none);
      case 2: pinocchio::aba(model, data, s.q, s.v, s.tau); return from_pinocchio(2, s, data.ddq, none, none);
      case 3:
        pinocchio::computeABADerivatives(model, data, s.q, s.v, s.tau);
        return from_pinocchio(3, s, data.ddq_dq, data.ddq_dv, data.Minv);
      default:
        pinocchio::computeRNEADerivatives(model, data, s.q, s.v, s.a);
        return from_pinocchio(4, s, data.dtau_dq, data.dtau_dv, none);
    }
  };

  // Accuracy.
  const std::size_t size[] = {NN, N, N, 3 * NN, 2 * NN};
  double worst[5][4] = {};
  for (int k = 0; k < kAccuracyStates; ++k) {
    const State& s = pool[static_cast<std::size_t>(k)];
    const eombench::Truth t = truth.at(s.q.data(), s.v.data(), s.u.data(), s.a.data());
    std::vector<double> expected[5] = {t.M, t.tau, t.qdd, {}, {}};
    for (auto* part : {&t.dqdd_dq, &t.dqdd_dv, &t.minv})
      expected[3].insert(expected[3].end(), part->begin(), part->end());
    for (auto* part : {&t.dtau_dq, &t.dtau_dv})
      expected[4].insert(expected[4].end(), part->begin(), part->end());
    for (int kernel = 0; kernel < 5; ++kernel) {
      if (expected[kernel].size() != size[kernel]) std::abort();
      const double e[4] = {error(eomgen(Folded{}, nullptr, kernel, s), expected[kernel]),
                           error(eomgen(Free{}, p, kernel, s), expected[kernel]),
                           error(codegen(kernel, s), expected[kernel]),
                           error(plain(kernel, s), expected[kernel])};
      for (int r = 0; r < 4; ++r) worst[kernel][r] = std::max(worst[kernel][r], e[r]);
    }
  }
  check_accuracy(robot, worst);

  // Timing: Pinocchio's raw outputs (no from_pinocchio); eomgen's kernels write straight into y.
  time_kernels<Folded, Free>(tag, pool, eomgen, [](const State& s) {
    return PinocchioInputs{s.q, s.v, s.a, s.tau, s.qva, s.qvtau};
  }, cg, model, data, p);
}

// ---- a free base: MuJoCo's humanoid and Romeo -------------------------------------------------
//
// humanoid.xml (27 velocities: the free joint and 21 hinges), read by eomgen-mjcf into its
// tree-form header; the Pinocchio model built from that header (eombench::tree_pinocchio_model: a
// JointModelFreeFlyer, the hinges, their armature). Its generalized forces are MuJoCo's (gear ·
// ctrl, joint springs and dampers). Romeo (tests/urdf/robots/published/romeo_small.urdf, from
// example-robot-data; 37 velocities: the free root and 31 revolute joints), read by eomgen's URDF
// reader with its root freed and its two inconsistent arm inertias taken as published
// (InertiaPolicy::warn, as the generated kernels take them); the Pinocchio model built from what
// it read (urdf_pinocchio_model: a JointModelFreeFlyer on the root link); Q = (0, u) − d⊙v.
// Either way Pinocchio's τ is the model's Q(q, v, u), precomputed per
// state, and Q's Jacobians (constant: Q is affine inside the control range, where the inputs are
// drawn) enter the conversion of Pinocchio's derivatives by the chain rule.
//
// Conventions (as in bench_pinocchio_contacts.cpp). eomgen: q = (x, quaternion w x y z, joints),
// v = (base velocity in world axes, angular velocity in base axes, joint rates), ∂/∂q along
// (δx world, δθ base axes, δjoints). Pinocchio: q = (x, quaternion x y z w, joints), v = (base
// velocity in base axes, the same ω, joint rates), ∂/∂q along its integrate() (δx in base axes to
// first order). With R the base's rotation and P = diag(Rᵀ, I): v_pin = P v, δ_pin = P δ,
// M = Pᵀ M_pin P, τ = Pᵀ τ_pin − Q, a_pin = P v̇ − (ω × v_lin,pin; 0) and back
// v̇ = P⁻¹ a_pin + (R (ω × v_lin,pin); 0); the derivatives by the chain rule (to_eomgen below).
// Every route's outputs are converted for the accuracy check; the timed calls take their inputs
// precomputed in their own conventions and leave their outputs raw (no conversion timed).
//
// Reference: Pinocchio's own algorithms in double, converted. tests/support's recursive
// implementation (the double-double reference of the other robots) reads a URDF robot with a free
// base, but none of MuJoCo's armature, joint springs and off-origin joint anchors, and
// PinocchioTruth differentiates along q itself, not the free joint's tangent. So the free-base
// accuracy figures are agreement with Pinocchio in double, not errors against a double-double
// truth.

Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d s;
  s << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return s;
}

struct FloatingState {
  VectorXd q, v, u, a;           // eomgen's (a: v̇ for the inverse-dynamics kernels)
  Eigen::Matrix3d R;             // the base's rotation
  VectorXd pq, pv, pa, ptau;     // Pinocchio's q, v, a, τ (= Q(q, v, u))
  VectorXd qva, qvtau;           // [pq; pv; pa] and [pq; pv; ptau]: the generated peer's inputs
  VectorXd Q;                    // eomgen's generalized forces at (q, v, u)
};

// Q(q, v, u) in eomgen's conventions (nv entries).
using GeneralizedForces = std::function<VectorXd(const VectorXd&, const VectorXd&, const VectorXd&)>;

template <class Folded, class Free>
void run_floating(const char* robot, pinocchio::Model model, const GeneralizedForces& generalized) {
  constexpr int nq = Folded::nq, nv = Folded::nv, nu = Folded::nu;
  constexpr std::size_t NV = nv, NN = NV * NV, NU = nu;
  static_assert(Folded::np == 0 && Free::nq == nq && Free::nv == nv && Free::nu == nu &&
                nq == nv + 1);
  model.name = robot;
  pinocchio::Data data(model);
  if (model.nq != nq || model.nv != nv || model.joints[1].shortname() != "JointModelFreeFlyer") {
    std::fprintf(stderr, "bench_pinocchio: %s: Pinocchio's model has other sizes than eomgen's\n",
                 robot);
    std::abort();
  }
  // Pinocchio adds joints parents first; eomgen numbers a URDF's joints in file order, which
  // need not be (Romeo: NeckYaw is coordinate 7, its ancestor TrunkYaw 23). pin_v[i]: eomgen's
  // velocity i in Pinocchio's v (the free joint's six in place); Pi, the permutation matrix.
  std::vector<int> pin_v(NV, -1);
  for (int i = 0; i < 6; ++i) pin_v[static_cast<std::size_t>(i)] = i;
  for (std::size_t j = 2; j < model.names.size(); ++j) {  // after the universe and the free joint
    const auto c = std::find(Folded::coordinate_names.begin(), Folded::coordinate_names.end(),
                             model.names[j]);
    if (c == Folded::coordinate_names.end() || model.nvs[j] != 1) {
      std::fprintf(stderr, "bench_pinocchio: %s: joint %s is no coordinate of eomgen's\n", robot,
                   model.names[j].c_str());
      std::abort();
    }
    pin_v[static_cast<std::size_t>(c - Folded::coordinate_names.begin() - 1)] = model.idx_vs[j];
  }
  MatrixXd Pi = MatrixXd::Zero(nv, nv);
  for (std::size_t i = 0; i < NV; ++i) {
    if (pin_v[i] < 0) {
      std::fprintf(stderr, "bench_pinocchio: %s: velocity %zu has no Pinocchio joint\n", robot, i);
      std::abort();
    }
    Pi(pin_v[i], static_cast<Eigen::Index>(i)) = 1;
  }
  // Q's Jacobians B = ∂Q/∂u, Kq = ∂Q/∂q (along eomgen's tangent), Kv = ∂Q/∂v by unit steps from
  // q = (0, identity, 0), v = 0, u = 0: exact for an affine Q (the derivatives' agreement checks
  // that it is). Q must not depend on the base's pose, and its free rows must vanish (then
  // Pinocchio's τ = P Q is Q itself).
  MatrixXd B(nv, nu), Kq = MatrixXd::Zero(nv, nv), Kv(nv, nv);
  {
    VectorXd q0 = VectorXd::Zero(nq), v0 = VectorXd::Zero(nv), u0 = VectorXd::Zero(nu);
    q0[3] = 1;
    const VectorXd t0 = generalized(q0, v0, u0);
    for (int i = 0; i < nq; ++i) {
      VectorXd q = q0;
      q[i] += 1;
      const VectorXd d = generalized(q, v0, u0) - t0;
      if (i >= 7) Kq.col(i - 1) = d;
      else if (d.cwiseAbs().maxCoeff() != 0) throw std::runtime_error("Q depends on the base's pose");
    }
    for (int i = 0; i < nv; ++i) Kv.col(i) = generalized(q0, VectorXd::Unit(nv, i), u0) - t0;
    for (int i = 0; i < nu; ++i) B.col(i) = generalized(q0, v0, VectorXd::Unit(nu, i)) - t0;
    if (t0.head<6>().cwiseAbs().maxCoeff() != 0)
      throw std::runtime_error("Q has a force on the free joint");
    if (B.topRows<6>().cwiseAbs().maxCoeff() != 0 || Kq.topRows<6>().cwiseAbs().maxCoeff() != 0 ||
        Kv.topRows<6>().cwiseAbs().maxCoeff() != 0)
      throw std::runtime_error("Q has a force on the free joint");
  }

  // States: positions and joint angles in ±1, a random unit quaternion, v in ±2, v̇ in ±2, the
  // inputs in ±0.9 (inside the control range ±1, where MuJoCo's clamp leaves them).
  std::vector<FloatingState> pool(kPool);
  {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> d(-1.0, 1.0);
    for (FloatingState& s : pool) {
      s.q.resize(nq), s.v.resize(nv), s.u.resize(nu), s.a.resize(nv);
      for (double& x : s.q) x = d(rng);
      s.q.segment<4>(3).normalize();
      for (double& x : s.v) x = 2 * d(rng);
      for (double& x : s.a) x = 2 * d(rng);
      for (double& x : s.u) x = 0.9 * d(rng);
      s.R = Eigen::Quaterniond(s.q[3], s.q[4], s.q[5], s.q[6]).toRotationMatrix();
      s.pq.resize(nq), s.pv.resize(nv), s.pa.resize(nv);
      const auto joints = Pi.bottomRightCorner(nv - 6, nv - 6);  // eomgen's joints → Pinocchio's
      s.pq << s.q.head<3>(), s.q[4], s.q[5], s.q[6], s.q[3], joints * s.q.tail(nq - 7);
      s.pv << s.R.transpose() * s.v.head<3>(), s.v.segment<3>(3), joints * s.v.tail(nv - 6);
      s.pa << s.R.transpose() * s.a.head<3>() - s.v.segment<3>(3).cross(s.pv.head<3>()),
          s.a.segment<3>(3), joints * s.a.tail(nv - 6);
      s.Q = generalized(s.q, s.v, s.u);
      s.ptau = Pi * s.Q;
      s.qva.resize(nq + 2 * nv), s.qvtau.resize(nq + 2 * nv);
      s.qva << s.pq, s.pv, s.pa;
      s.qvtau << s.pq, s.pv, s.ptau;
    }
  }

  const std::string tag = robot;
  Generated cg = generate(model, tag);
  auto &cg_crba = *cg.crba, &cg_rnea = *cg.rnea, &cg_aba = *cg.aba, &cg_daba = *cg.daba,
       &cg_drnea = *cg.drnea;

  // Pinocchio's outputs (generated or not; n×n blocks column-major, M, M⁻¹ and ∂τ/∂a right in
  // their upper triangles) in eomgen's conventions, into y: kernel 0 M_pin; 1 τ_pin; 2 a_pin;
  // 3 ∂a/∂q, ∂a/∂v, ∂a/∂τ (x: a_pin); 4 ∂τ/∂q, ∂τ/∂v, ∂τ/∂a (x: τ_pin).
  std::array<double, 3 * NN> y{};
  auto to_eomgen = [&](int kernel, const FloatingState& s, const MatrixXd& m1, const MatrixXd& m2,
                       const MatrixXd& m3, const VectorXd& x) -> const double* {
    MatrixXd D = MatrixXd::Identity(nv, nv), Dinv = MatrixXd::Identity(nv, nv);
    D.topLeftCorner<3, 3>() = s.R.transpose();
    Dinv.topLeftCorner<3, 3>() = s.R;
    const MatrixXd P = Pi * D, Pinv = Dinv * Pi.transpose();  // v_pin = P v
    const Eigen::Vector3d vl = s.pv.head<3>(), w = s.v.segment<3>(3);
    MatrixXd dv = MatrixXd::Zero(nv, nv);  // ∂v_pin/∂δ at fixed v: Rᵀ v_lin turns with δθ
    dv.block<3, 3>(0, 3) = skew(vl);
    switch (kernel) {
      case 0: Eigen::Map<MatrixXd>(y.data(), nv, nv) = P.transpose() * symmetric(m1) * P; break;
      case 1: Eigen::Map<VectorXd>(y.data(), nv) = P.transpose() * m1 - s.Q; break;
      case 2: {
        VectorXd r = Pinv * m1;
        r.head<3>() += s.R * w.cross(vl);
        Eigen::Map<VectorXd>(y.data(), nv) = r;
        break;
      }
      case 3: {  // v̇ = P⁻¹ a_pin + (R (ω × v_lin,pin); 0), a_pin(q, P v, Q(q, v, u))
        const MatrixXd Ft = symmetric(m3);
        const Eigen::Vector3d al = x.head<3>();
        MatrixXd H = MatrixXd::Zero(nv, nv);  // ∂(R (ω × v_lin,pin))/∂v_pin
        H.block<3, 3>(0, 0) = s.R * skew(w);
        H.block<3, 3>(0, 3) = -s.R * skew(vl);
        MatrixXd dq = Pinv * (m1 * P + m2 * dv + Ft * Pi * Kq) + H * dv;
        dq.block<3, 3>(0, 3) += -s.R * skew(al) - s.R * skew(w.cross(vl));
        Eigen::Map<MatrixXd>(y.data(), nv, nv) = dq;
        Eigen::Map<MatrixXd>(y.data() + NN, nv, nv) = (Pinv * m2 + H) * P + Pinv * Ft * Pi * Kv;
        Eigen::Map<MatrixXd>(y.data() + 2 * NN, nv, nu) = Pinv * Ft * Pi * B;
        break;
      }
      default: {  // τ = Pᵀ τ_pin(q, P v, a_pin(q, v, v̇)) − Q(q, v, u)
        const MatrixXd Ta = symmetric(m3);
        const Eigen::Vector3d al0 = s.R.transpose() * s.a.head<3>();  // Rᵀ v̇_lin
        MatrixXd da_q = MatrixXd::Zero(nv, nv), da_v = MatrixXd::Zero(nv, nv);
        da_q.block<3, 3>(0, 3) = skew(al0) - skew(w) * skew(vl);
        da_v.block<3, 3>(0, 0) = -skew(w) * s.R.transpose();
        da_v.block<3, 3>(0, 3) = skew(vl);
        MatrixXd dq = P.transpose() * (m1 * P + m2 * dv + Ta * da_q) - Kq;
        dq.block<3, 3>(0, 3) += -s.R * skew(Eigen::Vector3d(x.head<3>()));
        Eigen::Map<MatrixXd>(y.data(), nv, nv) = dq;
        Eigen::Map<MatrixXd>(y.data() + NN, nv, nv) = P.transpose() * (m2 * P + Ta * da_v) - Kv;
      }
    }
    return y.data();
  };
  const MatrixXd none;
  const VectorXd nothing;
  auto eomgen = [&](auto kernels, const double* pp, int kernel,
                    const FloatingState& s) -> const double* {
    return call_eomgen<decltype(kernels)>(kernel, pp, s, y.data());
  };
  auto codegen = [&](int kernel, const FloatingState& s) -> const double* {
    switch (kernel) {
      case 0: cg_crba(s.pq.data()); return to_eomgen(0, s, packed_upper(cg_crba.out(), nv), none, none, nothing);
      case 1:
        cg_rnea(s.qva.data());
        return to_eomgen(1, s, Eigen::Map<const VectorXd>(cg_rnea.out(), nv), none, none, nothing);
      case 2:
        cg_aba(s.qvtau.data());
        return to_eomgen(2, s, Eigen::Map<const VectorXd>(cg_aba.out(), nv), none, none, nothing);
      case 3: {  // a_pin from the generated aba
        cg_aba(s.qvtau.data());
        const VectorXd a = Eigen::Map<const VectorXd>(cg_aba.out(), nv);
        cg_daba(s.qvtau.data());
        const double* o = cg_daba.out();
        return to_eomgen(3, s, row_major(o, nv), row_major(o + NN, nv), row_major(o + 2 * NN, nv), a);
      }
      default: {  // τ_pin from the generated rnea
        cg_rnea(s.qva.data());
        const VectorXd t = Eigen::Map<const VectorXd>(cg_rnea.out(), nv);
        cg_drnea(s.qva.data());
        const double* o = cg_drnea.out();
        return to_eomgen(4, s, row_major(o, nv), row_major(o + NN, nv), row_major(o + 2 * NN, nv), t);
      }
    }
  };
  auto plain = [&](int kernel, const FloatingState& s) -> const double* {
    switch (kernel) {
      case 0: pinocchio::crba(model, data, s.pq); return to_eomgen(0, s, data.M, none, none, nothing);
      case 1: pinocchio::rnea(model, data, s.pq, s.pv, s.pa); return to_eomgen(1, s, data.tau, none, none, nothing);
      case 2: pinocchio::aba(model, data, s.pq, s.pv, s.ptau); return to_eomgen(2, s, data.ddq, none, none, nothing);
      case 3: {
        pinocchio::computeABADerivatives(model, data, s.pq, s.pv, s.ptau);
        const MatrixXd dq = data.ddq_dq, dv = data.ddq_dv, minv = data.Minv;
        pinocchio::aba(model, data, s.pq, s.pv, s.ptau);
        return to_eomgen(3, s, dq, dv, minv, data.ddq);
      }
      default: {
        pinocchio::computeRNEADerivatives(model, data, s.pq, s.pv, s.pa);
        const MatrixXd dq = data.dtau_dq, dv = data.dtau_dv, da = data.M;
        pinocchio::rnea(model, data, s.pq, s.pv, s.pa);
        return to_eomgen(4, s, dq, dv, da, data.tau);
      }
    }
  };

  // Accuracy: each route against Pinocchio's algorithms in double (see above).
  const std::size_t size[] = {NN, NV, NV, 2 * NN + NV * NU, 2 * NN};
  double worst[5][3] = {};
  for (int k = 0; k < kAccuracyStates; ++k) {
    const FloatingState& s = pool[static_cast<std::size_t>(k)];
    for (int kernel = 0; kernel < 5; ++kernel) {
      const double* r = plain(kernel, s);
      const std::vector<double> expected(r, r + size[kernel]);
      const double e[3] = {error(eomgen(Folded{}, nullptr, kernel, s), expected),
                           error(eomgen(Free{}, Free::parameter_values.data(), kernel, s), expected),
                           error(codegen(kernel, s), expected)};
      for (int route = 0; route < 3; ++route) worst[kernel][route] = std::max(worst[kernel][route], e[route]);
    }
  }
  check_accuracy(robot, worst);  // the first three routes: Pinocchio is the reference

  // Timing: raw outputs on every side, the inputs precomputed in each side's conventions.
  time_kernels<Folded, Free>(tag, pool, eomgen, [](const FloatingState& s) {
    return PinocchioInputs{s.pq, s.pv, s.pa, s.ptau, s.qva, s.qvtau};
  }, cg, model, data, Free::parameter_values.data());
}

#ifdef EOM_PIN_HUMANOID
template <class Folded, class Free, class Model> void run_humanoid(const char* robot) {
  run_floating<Folded, Free>(
      robot, eombench::tree_pinocchio_model<Model>(),
      [](const VectorXd& q, const VectorXd& v, const VectorXd& u) {
        VectorXd Q(Folded::nv);
        Model::template generalized_forces<double>(
            0.0, {q.data(), static_cast<std::size_t>(Folded::nq)},
            {v.data(), static_cast<std::size_t>(Folded::nv)},
            {u.data(), static_cast<std::size_t>(Folded::nu)}, Model::parameter_values,
            {Q.data(), static_cast<std::size_t>(Folded::nv)});
        return Q;
      });
}
#endif

// Romeo: its root freed, its inconsistent inertias taken as published (the kernels' options).
template <class Folded, class Free> void run_romeo(const char* robot, const std::string& urdf) {
  eom::urdf::ReadOptions options;
  options.free_root = true;
  options.inertia = eom::urdf::InertiaPolicy::warn;
  const eom::urdf::Robot parsed = eom::urdf::read(urdf, options);
  const std::vector<double> d = eombench::PinocchioTruth(parsed).damping();  // indexed like v
  if (d.size() != static_cast<std::size_t>(Folded::nv)) std::abort();
  run_floating<Folded, Free>(
      robot, eombench::urdf_pinocchio_model(parsed),
      [d](const VectorXd& q, const VectorXd& v, const VectorXd& u) {
        (void)q;
        VectorXd Q = VectorXd::Zero(v.size());
        Q.tail(u.size()) = u;  // one input per joint, none on the free joint
        for (Eigen::Index i = 0; i < v.size(); ++i) Q[i] -= d[static_cast<std::size_t>(i)] * v[i];
        return Q;
      });
}

}  // namespace

int main(int argc, char** argv) {
  // The generated peer's libraries live in (and are reused from) the working directory, or the
  // directory given as the first argument. Further arguments name the robots to run (default:
  // all), e.g. to check one robot's model without timing the others.
  if (argc > 1) {
    std::filesystem::create_directories(argv[1]);
    std::filesystem::current_path(argv[1]);
  }
  const std::vector<std::string> only(argv + std::min(argc, 2), argv + argc);
  auto wanted = [&](const std::string& robot) {
    return only.empty() || std::find(only.begin(), only.end(), robot) != only.end();
  };
  try {
    if (wanted("panda"))
      run_robot<pin_panda_folded::Kernels, pin_panda_free::Kernels>(
          "panda", EOM_ROBOTS_DIR "/panda.urdf");
    if (wanted("ur5"))
      run_robot<pin_ur5_folded::Kernels, pin_ur5_free::Kernels>("ur5", EOM_ROBOTS_DIR "/ur5.urdf");
    if (wanted("chain"))
      run_robot<pin_chain_folded::Kernels, pin_chain_free::Kernels>("chain",
                                                                    EOM_PINOCCHIO_CHAIN_URDF);
#ifdef EOM_PIN_HUMANOID
    if (wanted("humanoid"))
      run_humanoid<pin_humanoid_folded::Kernels, pin_humanoid_free::Kernels,
                   eom::mjcf_models::pin_humanoid_folded>("humanoid");
#endif
    if (wanted("romeo"))
      run_romeo<pin_romeo_folded::Kernels, pin_romeo_free::Kernels>("romeo",
                                                                    EOM_PINOCCHIO_ROMEO_URDF);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_pinocchio: %s\n", e.what());
    return 1;
  }
  return 0;
}
