// The codegen peer: eomgen's generated kernels against Pinocchio (its recursive algorithms in
// double) and Pinocchio's CppADCodeGen output (the same algorithms taped once, emitted as C,
// compiled with -O3 -march=native and called as raw C functions), side by side in one binary.
// Opt-in: built only when EOM_BENCH_PINOCCHIO_PREFIX names a Pinocchio + CppADCodeGen install
// (bench/pinocchio.cmake; bench/pinocchio.sh builds one from sources and runs this).
//
// Robots: the Panda, the UR5 (models/robots) and the planar chain of EOM_BENCH_PINOCCHIO_CHAIN
// links (bench/robots/chain<N>.urdf). Every one is read by eomgen's URDF reader; the Pinocchio
// model is built from what it read (pinocchio_model.hpp: moving joints in file order, fixed
// joints merged into their parent body, as Pinocchio's own URDF parser does), so both sides integrate the
// same numbers. eomgen's kernels come twice: every parameter folded (FIXED_PARAMETERS ALL) and
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
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <eomgen/urdf.hpp>

#include <pin_chain_folded.hpp>
#include <pin_chain_free.hpp>
#include <pin_panda_folded.hpp>
#include <pin_panda_free.hpp>
#include <pin_ur5_folded.hpp>
#include <pin_ur5_free.hpp>

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

// ---- one robot --------------------------------------------------------------------------------

const char* const kKernels[] = {"mass_matrix", "inverse_dynamics", "forward_dynamics",
                                "forward_dynamics_derivatives", "inverse_dynamics_derivatives"};
const char* const kRoutes[] = {"folded", "free", "codegen", "pinocchio"};  // in the printed lines

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

  std::printf("%s: generating Pinocchio's code (cached in the working directory)\n", robot);
  std::fflush(stdout);
  const std::string tag = robot;
  using Algorithm = eombench::PinocchioGenerated::Algorithm;
  auto generated = [&](Algorithm algorithm, const char* name) {
    return std::make_unique<eombench::PinocchioGenerated>(algorithm, model, tag + "_" + name,
                                                          EOM_PINOCCHIO_CC);
  };
  auto pcrba = generated(Algorithm::crba, "crba"), prnea = generated(Algorithm::rnea, "rnea"),
       paba = generated(Algorithm::aba, "aba"),
       pdaba = generated(Algorithm::aba_derivatives, "aba_derivatives"),
       pdrnea = generated(Algorithm::rnea_derivatives, "rnea_derivatives");
  auto &cg_crba = *pcrba, &cg_rnea = *prnea, &cg_aba = *paba, &cg_daba = *pdaba,
       &cg_drnea = *pdrnea;

  // Every route's outputs, in eomgen's conventions, for one state and kernel.
  std::array<double, 3 * NN> y{};
  auto eomgen = [&](auto kernels, const double* pp, int kernel, const State& s) -> const double* {
    using K = decltype(kernels);
    const double *q = s.q.data(), *v = s.v.data(), *u = s.u.data(), *a = s.a.data();
    switch (kernel) {
      case 0: K::mass_matrix(q, pp, y.data()); break;
      case 1: K::inverse_dynamics(0.0, q, v, a, u, pp, y.data()); break;
      case 2: K::forward_dynamics(0.0, q, v, u, pp, y.data()); break;
      case 3: K::forward_dynamics_derivatives(0.0, q, v, u, pp, y.data(), y.data() + NN,
                                              y.data() + 2 * NN); break;
      default: K::inverse_dynamics_derivatives(0.0, q, v, a, u, pp, y.data(), y.data() + NN);
    }
    return y.data();
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
  bool agree = true;
  for (int kernel = 0; kernel < 5; ++kernel) {
    std::printf("accuracy %-6s %-29s", robot, kKernels[kernel]);
    for (int r = 0; r < 4; ++r) {
      std::printf("  %s=%.1e", kRoutes[r], worst[kernel][r]);
      agree = agree && worst[kernel][r] <= kAgreement;
    }
    std::printf("\n");
  }
  std::fflush(stdout);
  if (!agree) {
    std::fprintf(stderr, "bench_pinocchio: %s: a route is off by more than %.0e: a model "
                         "mismatch; nothing is timed\n", robot, kAgreement);
    std::abort();
  }

  // Timing: each pair in alternating rounds. The timed calls skip from_pinocchio's conversions
  // (Pinocchio's raw outputs are timed); eomgen's write straight into y.
  auto at = [&](int i) -> const State& { return pool[static_cast<std::size_t>(i & (kPool - 1))]; };
  auto sink = [](const double* x) { eombench::sink = x[0]; };
  for (int kernel = 0; kernel < 5; ++kernel) {
    auto gen = [&](auto kernels, const double* pp) {
      return [&, kernels, kernel, pp](int i) { sink(eomgen(kernels, pp, kernel, at(i))); };
    };
    auto peer = [&](int i) {
      const State& s = at(i);
      switch (kernel) {
        case 0: cg_crba(s.q.data()); sink(cg_crba.out()); break;
        case 1: cg_rnea(s.qva.data()); sink(cg_rnea.out()); break;
        case 2: cg_aba(s.qvtau.data()); sink(cg_aba.out()); break;
        case 3: cg_daba(s.qvtau.data()); sink(cg_daba.out()); break;
        default: cg_drnea(s.qva.data()); sink(cg_drnea.out());
      }
    };
    auto recursive = [&](int i) {
      const State& s = at(i);
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

}  // namespace

int main(int argc, char** argv) {
  // The generated peer's libraries live in (and are reused from) the working directory, or the
  // directory given as the first argument.
  if (argc > 1) {
    std::filesystem::create_directories(argv[1]);
    std::filesystem::current_path(argv[1]);
  }
  try {
    run_robot<pin_panda_folded::Kernels, pin_panda_free::Kernels>(
        "panda", EOM_ROBOTS_DIR "/panda.urdf");
    run_robot<pin_ur5_folded::Kernels, pin_ur5_free::Kernels>("ur5", EOM_ROBOTS_DIR "/ur5.urdf");
    run_robot<pin_chain_folded::Kernels, pin_chain_free::Kernels>("chain", EOM_PINOCCHIO_CHAIN_URDF);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_pinocchio: %s\n", e.what());
    return 1;
  }
  return 0;
}
