// Integrating a model on its contact sets (CONTACTS, docs/CONTRACT.md §3): held on one set at a
// time, switched at touchdowns through the impulse, on the generated kernels as they are.
//
//   eom::OnContacts<K>    K's dynamics held on the contact set named by its parameters: its
//                         parameters are K's followed by the set s (−1: none, K's own
//                         forward_dynamics), the gains kd and kp, ρ, and for every frame of K
//                         the placement it is held at (3 position, 9 rotation column-major).
//   eom::Touchdowns<C, n, m> the events that switch sets: touchdown i fires when frame fᵢ's
//                         origin falls to heightᵢ while another set holds; its reset applies the
//                         impulse of setᵢ (impulse_dynamics, restitution e), holds its frames where
//                         they touched and switches the parameters to it. Liftoff j fires when
//                         frame fⱼ's normal force (its λ's z, world axes) falls to 0 while setⱼ
//                         holds; its reset switches to toⱼ (−1: none), v unchanged.
//
//   using C = eom::OnContacts<solo::Kernels>;
//   eom::Touchdowns<C, 1> touch(p_model, {.kd = 40, .kp = 400}, /*set=*/-1,
//                               {{{.set = stance, .frame = fl_foot}}}, /*restitution=*/0, q0);
//   auto r = eom::integrate<C>(t0, t1, x0, u, touch.parameters.data(), opt, touch.events(), log);
//
// How the drift is held (Baumgarte): contact_dynamics enforces J v̇ + a = −kd J v, so each
// frame's velocity error decays at the rate kd but its position, integrated from velocities a
// method gets right only to its order, would wander. OnContacts adds the position term:
// J v̇ + a = −kd J v − kp e, e the set's placement errors (point: x − x̄, world axes; 6d: then
// log(R R̄ᵀ), the rotation vector in world axes, the frame Jacobian's angular rows), by the
// correction Δv̇ = −M⁻¹Jᵀ(J M⁻¹Jᵀ + ρI)⁻¹ kp e (the same range-space solve the kernel makes,
// here in the runtime: the kernel's signature is the contract's). Each error then obeys
// ë + kd ė + kp e = 0 to first order: kp = kd²/4 damps it critically. kp = 0 leaves the
// kernel's v̇ untouched.
//
// The methods that run it are those that need only forward_dynamics: rk4, dopri5, dop853 (the
// others report Status::method_unavailable). K needs forward_dynamics (for s = −1), the energies,
// mass_matrix, frame_placement, frame_jacobian, contact_dynamics and impulse_dynamics.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <span>

#include "eom/integration/events.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

template <class K>
concept ContactDynamics =
    Dynamics<K> && (K::nc == 0) && (K::ncontact_sets > 0) &&
    requires(int s, double t, const double* x, double* y) {
      K::mass_matrix(x, x, y);
      K::frame_placement(s, x, x, y, y);
      K::frame_jacobian(s, x, x, y);
      { K::contact_dynamics(s, t, x, x, x, x, t, t, y, y) } -> std::same_as<bool>;
      { K::impulse_dynamics(s, x, x, x, t, t, y, y) } -> std::same_as<bool>;
    };

// The gains of OnContacts: kd [1/s] the kernel's velocity gain, kp [1/s²] the position gain,
// ρ the proximal parameter (> 0 for a redundant set, docs/CONTRACT.md §3).
struct ContactGains {
  double kd = 0, kp = 0, rho = 0;
};

// log(E) of a rotation matrix E (column-major) as its rotation vector: exact away from a half
// turn (an anchor error is tiny: near θ = π the axis from E − Eᵀ loses its digits).
inline void rotation_vector(const double* E, double* w) noexcept {
  const double s[3]{0.5 * (E[5] - E[7]), 0.5 * (E[6] - E[2]), 0.5 * (E[1] - E[3])};  // sinθ·axis
  const double sin = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  const double cos = 0.5 * (E[0] + E[4] + E[8] - 1);
  const double theta = std::atan2(sin, cos);
  const double scale = sin < 1e-8 ? 1 + theta * theta / 6 : theta / sin;
  for (int i = 0; i < 3; ++i) w[i] = scale * s[i];
}

template <ContactDynamics K> struct OnContacts {
  using Model = K;
  static constexpr int nq = K::nq, nv = nv_of<K>, nu = K::nu, nc = 0;
  static constexpr int nframes = K::nframes, ncontact_sets = K::ncontact_sets;
  // p's layout after K's parameters.
  static constexpr int set_index = K::np, kd_index = K::np + 1, kp_index = K::np + 2,
                       rho_index = K::np + 3, anchor_index = K::np + 4, anchor_size = 12;
  static constexpr int np = anchor_index + anchor_size * nframes;
  static constexpr int max_rows = *std::max_element(K::contact_rows.begin(), K::contact_rows.end());
  static constexpr std::array<double, np> parameter_values = [] {
    std::array<double, np> v{};
    for (int i = 0; i < K::np; ++i) v[i] = K::parameter_values[i];
    v[set_index] = -1;  // no set: K's own dynamics
    return v;
  }();

  static int set(const double* p) noexcept {
    const double s = p[set_index];
    return s >= 0 && s < ncontact_sets && s == std::floor(s) ? static_cast<int>(s) : -1;
  }
  static bool set_valid(const double* p) noexcept { return p[set_index] == -1 || set(p) >= 0; }
  static const double* anchor(const double* p, int f) noexcept { return p + anchor_index + anchor_size * f; }

  // Holds set s's frames where q places them (writes their anchors into p) and selects s.
  static void hold(int s, const double* q, double* p) noexcept {
    p[set_index] = s;
    if (s < 0 || s >= ncontact_sets) return;
    for (int c = K::contact_begin[s]; c < K::contact_begin[s + 1]; ++c) {
      double* a = p + anchor_index + anchor_size * K::contact_frames[c];
      K::frame_placement(K::contact_frames[c], q, p, a, a + 3);
    }
  }

  // e: set s's placement errors (contact_rows[s] values, in λ's order).
  static void placement_errors(int s, const double* q, const double* p, double* e) noexcept {
    int row = 0;
    for (int c = K::contact_begin[s]; c < K::contact_begin[s + 1]; ++c) {
      const int f = K::contact_frames[c];
      const double* a = anchor(p, f);
      double x[3], R[9];
      K::frame_placement(f, q, p, x, R);
      for (int i = 0; i < 3; ++i) e[row++] = x[i] - a[i];
      if (!K::contact_six_d[c]) continue;
      double E[9];  // R R̄ᵀ
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          E[i + 3 * j] = R[i] * a[3 + j] + R[i + 3] * a[3 + j + 3] + R[i + 6] * a[3 + j + 6];
      rotation_vector(E, e + row);
      row += 3;
    }
  }

  // v̇ and λ (contact_rows[s] values) with the position term; false as contact_dynamics.
  static bool dynamics(double t, const double* q, const double* v, const double* u, const double* p,
                       double* vdot, double* lambda) noexcept {
    const int s = set(p);
    const double kd = p[kd_index], kp = p[kp_index], rho = p[rho_index];
    if (!K::contact_dynamics(s, t, q, v, u, p, kd, rho, vdot, lambda)) return false;
    if (kp == 0) return true;
    if (!(kp > 0) || !std::isfinite(kp)) return fail(s, vdot, lambda);
    const int rows = K::contact_rows[s];
    std::array<double, max_rows> e{};
    placement_errors(s, q, p, e.data());
    // J (rows × nv, padded to max_rows) from the frames' Jacobian rows.
    std::array<double, 6 * nv> Jf;
    std::array<double, max_rows * nv> J{};
    int row = 0;
    for (int c = K::contact_begin[s]; c < K::contact_begin[s + 1]; ++c) {
      K::frame_jacobian(K::contact_frames[c], q, p, Jf.data());
      const int n = K::contact_six_d[c] ? 6 : 3;
      for (int i = 0; i < n; ++i, ++row)
        for (int k = 0; k < nv; ++k) J[row + max_rows * k] = Jf[i + 6 * k];
    }
    std::array<double, nv * nv> M;
    K::mass_matrix(q, p, M.data());
    if (!linalg::cholesky<double, nv>(M)) return fail(s, vdot, lambda);
    std::array<bool, max_rows> active{};
    for (int i = 0; i < rows; ++i) active[i] = true, e[i] *= -kp;
    // Δλ = (J M⁻¹Jᵀ + ρI)⁻¹(−kp e) in e, v̇ += M⁻¹Jᵀ Δλ
    if (!linalg::range_space_step<nv, max_rows>(M, J, active, rho, e, vdot)) return fail(s, vdot, lambda);
    for (int i = 0; i < rows; ++i) lambda[i] += e[i];
    return true;
  }

  static bool forward_dynamics(double t, const double* q, const double* v, const double* u,
                               const double* p, double* vdot) noexcept {
    if (!set_valid(p)) return fail(-1, vdot, nullptr);
    if (set(p) < 0) return K::forward_dynamics(t, q, v, u, p, vdot);
    std::array<double, max_rows> lambda;
    return dynamics(t, q, v, u, p, vdot, lambda.data());
  }
  static double kinetic_energy(const double* q, const double* v, const double* p) noexcept {
    return K::kinetic_energy(q, v, p);
  }
  static double potential_energy(const double* q, const double* p) noexcept {
    return K::potential_energy(q, p);
  }
  static void mass_matrix(const double* q, const double* p, double* M) noexcept { K::mass_matrix(q, p, M); }

 private:
  static bool fail(int s, double* vdot, double* lambda) noexcept {
    for (int k = 0; k < nv; ++k) vdot[k] = std::numeric_limits<double>::quiet_NaN();
    if (lambda && s >= 0)
      for (int i = 0; i < K::contact_rows[s]; ++i) lambda[i] = std::numeric_limits<double>::quiet_NaN();
    return false;
  }
};

// A touchdown: frame `frame`'s origin (K's frame index) falling to `height` (world z) closes
// contact set `set`.
struct Touchdown {
  int set = 0, frame = 0;
  double height = 0;
};

// A liftoff: while set `set` holds, frame `frame`'s normal force (the z component of its force
// in λ, world axes: the ground can push, not pull) falling to 0 opens the contact: set `to`
// holds from then (−1: none). A frame outside `set` makes the event function NaN (the
// integration stops with Status::event_not_finite).
struct Liftoff {
  int set = 0, frame = 0, to = -1;
};

// The touchdown and liftoff events of C = OnContacts<K> and the parameters they switch (events()
// lists the n touchdowns, then the m liftoffs). Touchdown i watches only while another set (or
// none) holds: then g = z − height, falling at the touchdown; while its set holds, g = +1, so
// that it cannot fire again until another set has taken over. Its reset applies impulse_dynamics
// of its set (restitution e, C's ρ) to v. Liftoff j watches only while its set holds: g = the
// frame's normal force from OnContacts' dynamics (kp term included), falling at the liftoff;
// else g = +1. Its reset leaves q and v as they are. Either switch keeps the anchors of the
// frames the new set shares with the old one and holds its other frames where they are. Holds
// its event functions and resets by reference: not copyable.
template <class C, int n, int m = 0> class Touchdowns {
 public:
  using K = typename C::Model;
  std::array<double, C::np> parameters;  // C's: give .data() as p

  // model_parameters: K's; set: the set holding at the start (−1: none), held where q0 places it.
  Touchdowns(std::span<const double> model_parameters, const ContactGains& gains, int set,
             const std::array<Touchdown, n>& touchdowns, double restitution, const double* q0,
             const std::array<Liftoff, m>& liftoffs = {}) noexcept
      : parameters(C::parameter_values), touchdowns_(touchdowns), liftoffs_(liftoffs), restitution_(restitution) {
    for (std::size_t k = 0; k < model_parameters.size() && k < static_cast<std::size_t>(K::np); ++k)
      parameters[k] = model_parameters[k];
    parameters[C::kd_index] = gains.kd, parameters[C::kp_index] = gains.kp;
    parameters[C::rho_index] = gains.rho;
    C::hold(set, q0, parameters.data());
    for (int i = 0; i < n; ++i) {
      height_[i] = {this, i};
      touch_[i] = {this, i};
      events_[i] = {.g = height_[i], .direction = EventDirection::falling,
                    .action = EventAction::reset, .reset = touch_[i]};
    }
    for (int j = 0; j < m; ++j) {
      force_[j] = {this, j};
      lift_[j] = {this, j};
      events_[n + j] = {.g = force_[j], .direction = EventDirection::falling,
                        .action = EventAction::reset, .reset = lift_[j]};
    }
  }
  Touchdowns(const Touchdowns&) = delete;
  Touchdowns& operator=(const Touchdowns&) = delete;

  std::span<const Event> events() const noexcept { return events_; }
  int set() const noexcept { return C::set(parameters.data()); }
  // The last touchdown's impulse (contact_rows of its set) and its index (−1 before any).
  const std::array<double, C::max_rows>& impulse() const noexcept { return impulse_; }
  int last() const noexcept { return last_; }
  // The last liftoff's index (−1 before any).
  int last_liftoff() const noexcept { return last_liftoff_; }

  // For a loop that changes u between integrations (a sampled controller): the normal force
  // depends on u at once, so a new u can take it below 0 at the very start of the next
  // integration, where no crossing is there to locate. Called with the new u before integrating,
  // this applies the first liftoff whose set holds and whose normal force at (t, q, v, u) is ≤ 0
  // (as its event's reset would) and returns its index, else −1.
  int lift(double t, const double* q, const double* v, const double* u) noexcept {
    for (int j = 0; j < m; ++j) {
      if (C::set(parameters.data()) != liftoffs_[j].set) continue;
      const double force = force_[j](t, q, v, u, parameters.data());
      if (force <= 0) {
        switch_to(liftoffs_[j].to, q);
        return last_liftoff_ = j;
      }
    }
    return -1;
  }

  // Where frame f's force starts in set s's λ (−1: f is not in s).
  static int row_of(int s, int f) noexcept {
    if (s < 0 || s >= K::ncontact_sets) return -1;
    for (int c = K::contact_begin[s], row = 0; c < K::contact_begin[s + 1]; row += K::contact_six_d[c] ? 6 : 3, ++c)
      if (K::contact_frames[c] == f) return row;
    return -1;
  }

 private:
  // Switches the parameters to set `to` (−1: none): its frames held where q places them, but those
  // it shares with the set holding now, which keep their anchors.
  void switch_to(int to, const double* q) noexcept {
    const int from = C::set(parameters.data());
    std::array<double, C::anchor_size * C::nframes> kept;
    std::copy_n(C::anchor(parameters.data(), 0), kept.size(), kept.begin());
    C::hold(to, q, parameters.data());
    if (from < 0 || to < 0) return;
    for (int c = K::contact_begin[to]; c < K::contact_begin[to + 1]; ++c)
      for (int b = K::contact_begin[from]; b < K::contact_begin[from + 1]; ++b)
        if (K::contact_frames[b] == K::contact_frames[c])
          std::copy_n(&kept[C::anchor_size * K::contact_frames[c]], C::anchor_size,
                      parameters.data() + C::anchor_index + C::anchor_size * K::contact_frames[c]);
  }

  struct Height {
    Touchdowns* self;
    int i;
    double operator()(double, const double* q, const double*, const double*, const double* p) const noexcept {
      const Touchdown& d = self->touchdowns_[i];
      if (C::set(p) == d.set) return 1.0;
      double x[3], R[9];
      K::frame_placement(d.frame, q, p, x, R);
      return x[2] - d.height;
    }
  };
  struct Touch {
    Touchdowns* self;
    int i;
    bool operator()(double, double* q, double* v, const double*, const double* p) noexcept {
      if (p != self->parameters.data()) return false;  // the switch must reach the integration
      const int to = self->touchdowns_[i].set;
      std::array<double, C::nv> v_plus;
      if (!K::impulse_dynamics(to, q, v, p, self->restitution_, p[C::rho_index], v_plus.data(),
                               self->impulse_.data()))
        return false;
      std::copy(v_plus.begin(), v_plus.end(), v);
      self->switch_to(to, q);
      self->last_ = i;
      return true;
    }
  };
  struct NormalForce {
    Touchdowns* self;
    int j;
    double operator()(double t, const double* q, const double* v, const double* u, const double* p) const noexcept {
      const Liftoff& d = self->liftoffs_[j];
      if (C::set(p) != d.set) return 1.0;
      const int row = row_of(d.set, d.frame);
      std::array<double, C::nv> vdot;
      std::array<double, C::max_rows> lambda;
      if (row < 0 || !C::dynamics(t, q, v, u, p, vdot.data(), lambda.data()))
        return std::numeric_limits<double>::quiet_NaN();
      return lambda[row + 2];
    }
  };
  struct Lift {
    Touchdowns* self;
    int j;
    bool operator()(double, double* q, double*, const double*, const double* p) noexcept {
      if (p != self->parameters.data()) return false;  // the switch must reach the integration
      self->switch_to(self->liftoffs_[j].to, q);
      self->last_liftoff_ = j;
      return true;
    }
  };
  std::array<Touchdown, n> touchdowns_;
  std::array<Liftoff, m> liftoffs_;
  double restitution_;
  std::array<double, C::max_rows> impulse_{};
  int last_ = -1, last_liftoff_ = -1;
  std::array<Height, n> height_{};
  std::array<Touch, n> touch_{};
  std::array<NormalForce, m> force_{};
  std::array<Lift, m> lift_{};
  std::array<Event, n + m> events_{};
};

}  // namespace eom
