// Latches: locks aᵢᵀq = const that engage during a run (a hinge that latches when it reaches its
// stop) and hold exactly from then on, on an unconstrained model's own kernels.
//
//   eom::Locked<K, Rows>    K's dynamics with the locks in Rows switched on by parameters: its
//                           parameters are K's followed by one flag per lock (0 free, 1 locked);
//                           q̈ = q̈_free − M⁻¹Aᵀ(AM⁻¹Aᵀ)⁻¹A q̈_free over the locked rows A.
//   eom::Latches<L>         the events that engage them: lock i latches when aᵢᵀq reaches
//                           targetᵢ; its reset sets the flag and applies the perfectly inelastic
//                           impulse q̇⁺ = q̇ − M⁻¹Aᵀ(AM⁻¹Aᵀ)⁻¹A q̇ (A: the locked rows, the new
//                           one included), which stops every locked row's rate.
//
//   struct Hinges { static constexpr int count = 1;              // the rows aᵢ, constant
//                   static constexpr std::array<std::array<double, 2>, 1> rows{{{-1, 1}}}; };
//   using L = eom::Locked<K, Hinges>;
//   eom::Latches<L> latches(p0, targets, x0);       // p0: K's parameters; not copyable
//   auto r = eom::integrate<L>(t0, t1, x0, u, latches.parameters.data(), opt, latches.events(), log);
//
// Why a switched constraint: the rows are constant, so A q̈ = 0 in every stage makes every
// Runge–Kutta step (and its dense output) keep A q̇ and A q unchanged: a locked hinge stays at its
// latch angle to round-off, with the same coordinates, the generated kernels as they are, no
// stiffness. The methods that run it are those that need only forward_dynamics: rk4, dopri5,
// dop853 (the others report Status::method_unavailable). K must be unconstrained (nc = 0).
//
// A free joint (eom/model/free_joint.hpp): a row aᵢ still has nq entries (aᵢᵀq), and those of the
// quaternion must be 0 (an orientation is not linear in q; checked at compile time). The row then
// acts on v through the same entries (x, y, z and the joints have q̇ = v), M and the impulse are
// K's nv × nv ones, and the latch angle holds as above.
//
// The impulse conserves every momentum component zᵀp (p = M q̇) with A z = 0, and removes the
// kinetic energy ½ (Aq̇)ᵀ(AM⁻¹Aᵀ)⁻¹(Aq̇); when only the new row moves, ½ r²/(aᵀ W a) with r its
// rate and W the inverse mass matrix of the model already locked (M⁻¹ when nothing was).
//
// The parameter change: the reset writes the flag into Latches::parameters, the array the
// integration reads p from (a reset given another p fails: Status::event_reset_failed). A locked
// lock's event function is constant (+1), so it cannot fire again.
#pragma once

#include <array>
#include <cstddef>
#include <span>

#include "eom/integration/events.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

template <Dynamics K, class R> struct Locked {
  using Rows = R;
  static_assert(K::nc == 0, "eom::Locked: the model must be unconstrained");
  static_assert(Rows::count >= 1 && Rows::rows.size() == static_cast<std::size_t>(Rows::count) &&
                    Rows::rows[0].size() == static_cast<std::size_t>(K::nq),
                "eom::Locked: Rows::rows must hold Rows::count rows of nq entries");
  static constexpr int nq = K::nq, nv = nv_of<K>, nu = K::nu, nc = 0, locks = Rows::count;
  static_assert(layout_of<K>().free_joint_only(),
                "eom::Locked: ball joints are not supported yet (a free joint's quaternion only)");
  // The rows over v: a free joint's quaternion entries (which must be 0) dropped.
  static constexpr std::array<std::array<double, nv>, locks> velocity_rows = [] {
    std::array<std::array<double, nv>, locks> a{};
    for (int i = 0; i < locks; ++i)
      for (int k = 0; k < nv; ++k)
        a[i][k] = nv == nq || k < 3      ? Rows::rows[i][k]
                  : k >= free_joint_nv ? Rows::rows[i][k + 1]
                                       : 0.0;  // ω: the quaternion's entries are 0
    return a;
  }();
  static_assert([] {
    if constexpr (nv != nq)
      for (int i = 0; i < locks; ++i)
        for (int k = 3; k < free_joint_nq; ++k)
          if (Rows::rows[i][k] != 0) return false;
    return true;
  }(), "eom::Locked: with a free joint, a row's quaternion entries (qw, qx, qy, qz) must be 0");
  static constexpr int np = K::np + locks;
  static constexpr std::array<double, np> parameter_values = [] {
    std::array<double, np> v{};  // every lock free
    for (int i = 0; i < K::np; ++i) v[i] = K::parameter_values[i];
    return v;
  }();

  static bool locked(const double* p, int i) noexcept { return p[K::np + i] != 0; }

  // The rows column-major (locks × nv), as linalg::range_space_step takes them.
  static constexpr std::array<double, locks * nv> row_matrix = [] {
    std::array<double, locks * nv> A{};
    for (int i = 0; i < locks; ++i)
      for (int k = 0; k < nv; ++k) A[i + locks * k] = velocity_rows[i][k];
    return A;
  }();

  // v − M⁻¹Aᵀ(AM⁻¹Aᵀ)⁻¹A v over the locked rows A: the M-orthogonal projection onto A v = 0.
  static bool project(const double* q, const double* p, double* v) noexcept {
    std::array<bool, locks> active{};
    bool any = false;
    for (int i = 0; i < locks; ++i) any = (active[i] = locked(p, i)) || any;
    if (!any) return true;
    std::array<double, nv * nv> M;
    K::mass_matrix(q, p, M.data());
    if (!linalg::cholesky<double, nv>(M)) return false;
    std::array<double, locks> r{};  // −A v
    for (int i = 0; i < locks; ++i)
      for (int k = 0; k < nv; ++k) r[i] -= velocity_rows[i][k] * v[k];
    return linalg::range_space_step<nv, locks>(M, row_matrix, active, 0.0, r, v);  // dependent locked rows: false
  }

  static bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                               const double* p, double* qdd) noexcept {
    return K::forward_dynamics(t, q, qd, u, p, qdd) && project(q, p, qdd);
  }
  static double kinetic_energy(const double* q, const double* qd, const double* p) noexcept {
    return K::kinetic_energy(q, qd, p);
  }
  static double potential_energy(const double* q, const double* p) noexcept {
    return K::potential_energy(q, p);
  }
  static void mass_matrix(const double* q, const double* p, double* M) noexcept { K::mass_matrix(q, p, M); }
};

// The latch events of a Locked model L and the parameters they switch. Lock i latches when
// aᵢᵀq reaches targets[i] from the side x0 starts on (a lock already at its target at x0 must be
// locked in p0 by the caller). Holds its event functions and resets by reference: not copyable.
template <class L> class Latches {
 public:
  static constexpr int nq = L::nq, locks = L::locks;
  std::array<double, L::np> parameters;  // the model's, then the flags; give .data() as p

  Latches(std::span<const double> model_parameters, const std::array<double, locks>& targets,
          const StateFor<L>& x0) noexcept
      : parameters(L::parameter_values) {
    for (std::size_t k = 0; k < model_parameters.size() && k < L::np - locks; ++k)
      parameters[k] = model_parameters[k];
    for (int i = 0; i < locks; ++i) {
      gap_[i] = {i, targets[i], row(x0.data(), i) < targets[i] ? 1.0 : -1.0};
      latch_[i] = {this, i};
      events_[i] = {.g = gap_[i], .direction = EventDirection::rising, .action = EventAction::reset,
                    .reset = latch_[i]};
    }
  }
  Latches(const Latches&) = delete;
  Latches& operator=(const Latches&) = delete;

  std::span<const Event> events() const noexcept { return events_; }
  bool locked(int i) const noexcept { return L::locked(parameters.data(), i); }
  static double row(const double* q, int i) noexcept {
    double s = 0;
    for (int k = 0; k < nq; ++k) s += L::Rows::rows[i][k] * q[k];
    return s;
  }

 private:
  struct Gap {  // < 0 before the latch, crosses 0 rising at it; +1 once locked
    int i;
    double target, side;
    double operator()(double, const double* q, const double*, const double*, const double* p) const noexcept {
      return L::locked(p, i) ? 1.0 : side * (row(q, i) - target);
    }
  };
  struct Latch {
    Latches* self;
    int i;
    bool operator()(double, double* q, double* qd, const double*, const double* p) noexcept {
      if (p != self->parameters.data()) return false;  // the flag must reach the integration
      self->parameters[L::np - locks + i] = 1;
      return L::project(q, p, qd);
    }
  };
  std::array<Gap, locks> gap_{};
  std::array<Latch, locks> latch_{};
  std::array<Event, locks> events_{};
};

}  // namespace eom
