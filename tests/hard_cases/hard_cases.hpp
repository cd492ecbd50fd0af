// The hard cases of docs/hard-cases/ , as measurement functions shared by the
// tests in this folder and the report program bench/hard_cases.cpp:
//
//   spherical_*      the spherical pendulum in polar angles passing near its coordinate
//                    singularity (θ = 0), against the same motion in Cartesian coordinates
//                    integrated in double-double;
//   chain_case       forward dynamics of long chains with light links carrying a heavy tip
//                    (ill-conditioned M), double against long double;
//   divergence_time  the chaotic double pendulum: when a double-precision run leaves the
//                    double-double reference, as a function of the tolerance;
//   near_dead_point  the closed chain approaching its dead point (C M⁻¹Cᵀ ill-conditioned),
//                    double against double-double, and the statuses at the dead point itself.
//
// The functions' bodies are in hard_cases.cpp, compiled once (eom_hard_cases_support): their
// integrations instantiate every integrator for three models, which took each including test
// 20-30 s to compile; the templates stay here.
//
// qd's double-double arithmetic is used here: every translation unit that includes this header
// must be compiled with -ffp-contract=off (an FMA-contracted two_prod/two_sum breaks dd_real).
#pragma once

#include <qd/dd_real.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <eom/integration/high_precision.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/reference/reference.hpp>

#include <models/chain.hpp>
#include <models/double_pendulum.hpp>
#include <models/spherical_pendulum.hpp>

namespace hard_cases {

constexpr double eps = std::numeric_limits<double>::epsilon();

template <std::size_t n> bool all_finite(const std::array<double, n>& x) {
  return std::all_of(x.begin(), x.end(), [](double v) { return std::isfinite(v); });
}

// ---- the spherical pendulum near its pole ------------------------------------------------------

using Polar = eom::Reference<eom::models::SphericalPendulum>;
using Cartesian = eom::Reference<eom::models::CartesianSphericalPendulum>;

struct SphericalStart {
  eom::StateOf<2> polar;      // (θ, φ, θ̇, φ̇)
  eom::StateOf<3> cartesian;  // the same state in (x, y, z, ẋ, ẏ, ż)
  double Lz = 0, energy = 0;
};

// At rest in θ at θ0 (φ = 0), with the L_z that makes θ turn back at theta_min: θ̇ = 0 at both
// turning points, so E and L_z = m l² sin²θ φ̇ give
//   L_z² / (2 m l²) · (1/sin²θmin − 1/sin²θ0) = m g l (cos θmin − cos θ0).
// theta_min = 0 gives L_z = 0: a planar swing through the pole.
SphericalStart spherical_start(double theta0, double theta_min);

// The start s for a given polar state (θ ≠ π): L_z and E from it.
SphericalStart spherical_start_from(const eom::StateOf<2>& x);

std::array<double, 3> polar_position(const eom::StateOf<2>& x);

// The mass's positions at `times` from the Cartesian (singularity-free) model integrated in
// double-double by extrapolation (eom/integration/high_precision.hpp). Empty when that fails.
std::vector<std::array<double, 3>> spherical_reference(const SphericalStart& s,
                                                       const std::vector<double>& times,
                                                       double tolerance = 1e-26,
                                                       int columns = 10);

struct PassageRun {
  eom::Status status = eom::Status::ok;
  double t_end = 0;            // time reached
  long accepted = 0, rejected = 0;
  double position_error = 0;   // max over the output times reached of |r − r_ref|∞ [m]
  double lz_error = 0;         // max |L_z − L_z(0)| [kg m²/s]
  double energy_error = 0;     // max |E − E(0)| [J]
  bool finite = true;          // every state seen, and the final one, finite
};

// The polar model from s by `method` at rtol = atol = tol (fixed-step methods: step h), with
// dense output at `times` compared against ref (spherical_reference at the same times).
PassageRun polar_run(eom::Method method, double tol, double h, const SphericalStart& s,
                     const std::vector<double>& times,
                     const std::vector<std::array<double, 3>>& ref);

// The Cartesian model, projected onto the constraint after every step.
PassageRun cartesian_run(eom::Method method, double tol, double h, const SphericalStart& s,
                         const std::vector<double>& times,
                         const std::vector<std::array<double, 3>>& ref);

std::vector<double> uniform_times(double dt, double t1);

// ---- long chains with light links and a heavy tip ----------------------------------------------

// The paper's inflated-beam chain (links of 0.01 kg, 0.5 m, hinge dampers 4e-3 N·m·s) whose last
// link carries tip_ratio times a link's mass (a payload on a light boom). tip_ratio = 1 is the
// uniform chain.
template <int N> std::array<double, 4 * N + 1> light_chain_parameters(double tip_ratio) {
  auto p = eom::models::Chain<N>::parameter_values;
  const double m = p[N - 1] * tip_ratio, l = p[2 * N - 1];
  p[N - 1] = m;
  p[3 * N - 1] = m * l * l / 12;
  return p;
}

enum class ChainShape { hanging, stowed, random };
constexpr const char* to_string(ChainShape s) {
  return s == ChainShape::hanging ? "hanging, gently curved"
         : s == ChainShape::stowed ? "stowed accordion (±5° folds)"
                                   : "random angles";
}

// Configurations (absolute link angles from the horizontal) and hinge rates (seeded, ±0.5 rad/s).
template <int N> eom::StateOf<N> chain_state(ChainShape shape) {
  std::mt19937 gen(12345);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  eom::StateOf<N> x{};
  const double pi = std::numbers::pi;
  for (int i = 0; i < N; ++i) {
    switch (shape) {
      case ChainShape::hanging: x[i] = -pi / 2 + 0.3 * std::sin(pi * (i + 0.5) / N); break;
      case ChainShape::stowed: x[i] = (i % 2 == 0 ? -5.0 : 185.0) * pi / 180; break;
      case ChainShape::random: x[i] = pi * unit(gen); break;
    }
  }
  for (int i = 0; i < N; ++i) x[N + i] = 0.5 * unit(gen);
  return x;
}

struct ChainCase {
  double cond = 0;         // κ₂(M)
  double scaled_cond = 0;  // κ₂(D⁻¹ M D⁻¹), D = diag(M)^½: what a Cholesky solve's error follows
  bool ok = false, ok_wide = false;  // forward_dynamics in double / long double returned true
  bool nan_on_failure = true;        // on false, the output is NaN (the contract), never a number
  double rel_error = 0;    // ‖q̈ − q̈_wide‖∞ / ‖q̈_wide‖∞
  double bound = 0;        // N · κ_s · ε (see chain_error_bound)
  double qdd_norm = 0;     // ‖q̈_wide‖∞
};

// The bound the forward dynamics error is held to: Cholesky's normwise error on the diagonally
// scaled system (van der Sluis: it does not depend on the scaling) is ≤ c(n)·κ(D⁻¹MD⁻¹)·ε with
// c(n) = O(n); M and f are formed with relative errors of a few ε per entry.
inline double chain_error_bound(int n, double scaled_cond) { return n * scaled_cond * eps; }

template <int N> double condition_number(const Eigen::MatrixXd& A) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(A, Eigen::EigenvaluesOnly);
  return es.eigenvalues().maxCoeff() / es.eigenvalues().minCoeff();
}

// Reference<Chain<N>> at N = 50 needs ~30 MB of stack: it takes them from its heap stack
// (eom/reference/heap_stack.hpp), so this runs on any thread.
template <int N> ChainCase chain_case(double tip_ratio, ChainShape shape) {
  using Chain = eom::models::Chain<N>;
  using R = eom::Reference<Chain>;
  using Wide = eom::Reference<Chain, long double>;
  const auto p = light_chain_parameters<N>(tip_ratio);
  const auto x = chain_state<N>(shape);
  ChainCase c;
  std::vector<double> M(N * N);
  R::mass_matrix(x.data(), p.data(), M.data());
  const Eigen::Map<const Eigen::MatrixXd> Mm(M.data(), N, N);
  const Eigen::VectorXd d = Mm.diagonal().cwiseSqrt().cwiseInverse();
  c.cond = condition_number<N>(Mm);
  c.scaled_cond = condition_number<N>(d.asDiagonal() * Mm * d.asDiagonal());
  c.bound = chain_error_bound(N, c.scaled_cond);

  std::array<double, N> qdd;
  c.ok = R::forward_dynamics(0.0, x.data(), x.data() + N, nullptr, p.data(), qdd.data());
  std::array<long double, 2 * N> xw;
  std::array<long double, 4 * N + 1> pw;
  std::array<long double, N> qddw;
  for (int i = 0; i < 2 * N; ++i) xw[i] = x[i];
  for (int i = 0; i < 4 * N + 1; ++i) pw[i] = p[i];
  c.ok_wide = Wide::forward_dynamics(0.0L, xw.data(), xw.data() + N, nullptr, pw.data(), qddw.data());
  if (!c.ok) c.nan_on_failure = std::all_of(qdd.begin(), qdd.end(), [](double v) { return std::isnan(v); });
  if (c.ok && c.ok_wide) {
    double err = 0, size = 0;
    for (int i = 0; i < N; ++i) {
      err = std::max(err, static_cast<double>(std::abs(qdd[i] - qddw[i])));
      size = std::max(size, static_cast<double>(std::abs(qddw[i])));
    }
    c.rel_error = err / size;
    c.qdd_norm = size;
  }
  return c;
}

// ---- the chaotic double pendulum: divergence time against tolerance ----------------------------

using DoublePendulumState = std::array<double, 4>;

struct DoublePendulumReference {
  std::vector<double> times;
  std::vector<DoublePendulumState> x;
  eom::Status status = eom::Status::ok;
  long steps = 0;
};

// The chaotic start (a1 = 2.0, a2 = 2.5, at rest; optionally perturbed) in double-double by
// extrapolation, at times dt, 2dt, ..., t1.
DoublePendulumReference double_pendulum_reference(double t1, double dt, double tolerance,
                                                  double perturbation = 0);

double max_difference(const DoublePendulumState& a, const DoublePendulumState& b);

// The first reference time at which a and b differ by more than threshold (max norm over the
// state); +∞ when they never do.
double first_departure(const std::vector<double>& times, const std::vector<DoublePendulumState>& a,
                       const std::vector<DoublePendulumState>& b, double threshold);

struct Divergence {
  eom::Status status = eom::Status::ok;
  double time = 0;  // first output time with |x − x_ref|∞ > threshold (+∞: never)
  long accepted = 0, evaluations = 0;
  bool finite = true;
};

// K: the double pendulum's kernels (generated: Taylor needs taylor_coefficients).
template <class K>
Divergence divergence_time(eom::Method method, double tol, const DoublePendulumReference& ref,
                           double threshold = 1e-2) {
  using DP = eom::models::DoublePendulum;
  const auto& p = K::parameter_values;
  const eom::StateOf<2> x0{DP::initial_q[0], DP::initial_q[1], 0.0, 0.0};
  eom::IntegrationOptions opt;
  opt.method = method;
  opt.rtol = opt.atol = tol;
  opt.output_times = ref.times;
  opt.max_steps = 10000000;
  std::vector<DoublePendulumState> x;
  x.reserve(ref.times.size());
  Divergence d;
  const auto r = eom::integrate<K>(0.0, ref.times.back(), x0, nullptr, p.data(), opt,
                                   [&](double, const eom::StateOf<2>& s) {
                                     d.finite = d.finite && all_finite(s);
                                     x.push_back(s);
                                   });
  d.status = r.status, d.accepted = r.accepted, d.evaluations = r.evaluations;
  d.finite = d.finite && all_finite(r.x);
  d.time = first_departure(ref.times, x, ref.x, threshold);
  return d;
}

struct Line {
  double slope = 0, intercept = 0;
};
Line least_squares(const std::vector<double>& x, const std::vector<double>& y);

// ---- the closed chain near its dead point -------------------------------------------------------

using ClosedChain = eom::Reference<eom::models::ClosedChain5>;

struct DeadPointCase {
  double a = 0;            // fold size (see near_dead_point)
  double schur_cond = 0;   // κ₂(S), S = C M⁻¹ Cᵀ
  double schur_scaled_cond = 0;  // κ₂(D⁻¹ S D⁻¹), D = diag(S)^½: what the Cholesky solve of S sees
  double mass_cond = 0;    // κ₂(M)
  bool ok = false, ok_wide = false;
  bool nan_on_failure = true;
  double qdd_error = 0;    // ‖q̈ − q̈_dd‖∞ / ‖q̈_dd‖∞, q̈ from the forward_dynamics kernel
  double mu_error = 0;     // ‖μ − μ_dd‖∞ / ‖μ_dd‖∞, the constraint forces (Lagrange multipliers)
  double qdd_norm = 0, mu_norm = 0;  // ‖q̈_dd‖∞, ‖μ_dd‖∞
};

// The five-link closed chain in a shallow asymmetric fold of size a, at rest, drive off (t = 0):
// θ₁..θ₄ = a·(2, −1, 1.5, −0.7), θ₅ closing the loop vertically (Σ sin θᵢ = 0), the second pin
// placed at Σ cos θᵢ. As a → 0 the chain straightens into its dead point, where C loses rank:
// the x-row of C is −(sin θᵢ) = O(a), so S = C M⁻¹Cᵀ has an O(a²) eigenvalue and the horizontal
// constraint force (the tension needed to hold a nearly straight chain against gravity) grows
// like 1/a.
DeadPointCase near_dead_point(double a);

struct DeadPointStop {
  eom::Method method;
  eom::Status status;
  double t;
  bool finite;
};

// Every method started exactly at the dead point (the chain straight between pins 5 m apart).
std::vector<DeadPointStop> dead_point_stops();

}  // namespace hard_cases
