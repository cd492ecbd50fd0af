// Planar chains of rigid links in the paper's coordinates (absolute angles θᵢ of each link from
// the horizontal, mass centres built recursively from link i to link i+1), written in the body
// form: the generator and the reference derive M = Σ mᵢAᵢᵀAᵢ + IᵢBᵢᵀBᵢ from the positions alone.
//
//   Chain<N>        an open chain pinned at the origin: the paper's inflated-beam deployment
//                   (N = 10) and the scaling benchmark model.
//   ClosedChain5    five links pinned at both ends (two loop-closure constraints), driven by a
//                   sinusoidal torque on link 1: the paper's closed-chain example.
//
// Link i runs from joint i to joint i+1 (joint 1 is the pin at the origin), its mass centre at
// its middle; y points up and gravity acts along −y. Hinge i joins link i−1 (the ground for
// i = 1) to link i; its damper with coefficient cᵢ resists the relative rate ωᵢ = θ̇ᵢ − θ̇ᵢ₋₁
// (θ̇₀ = 0), pushing the two links in opposite directions:
//   Qᵢ = −cᵢ (θ̇ᵢ − θ̇ᵢ₋₁) + cᵢ₊₁ (θ̇ᵢ₊₁ − θ̇ᵢ)      (no cₙ₊₁ term for the last link).
// The paper prints only the second term (eq. 31); both are needed for q̇ᵀQ = −Σ cᵢ ωᵢ² ≤ 0,
// i.e. for the dampers to dissipate energy rather than create it.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <string_view>

#include <eom/model/model.hpp>

namespace eom::models {

namespace chain_detail {

// Parameter names "m1".."mN", "l1".., "I1".., "c1".., "g" for a chain of N links, built at
// compile time (the contract wants a std::array of names for any N).
template <int N> struct Names {
  static constexpr int count = 4 * N + 1;
  static constexpr auto storage = [] {
    std::array<std::array<char, 8>, count> s{};
    constexpr char prefix[] = {'m', 'l', 'I', 'c'};
    for (int k = 0; k < 4; ++k)
      for (int i = 0; i < N; ++i) {
        auto& name = s[k * N + i];
        int n = i + 1, len = 1;
        name[0] = prefix[k];
        char digits[4]{};
        int d = 0;
        while (n > 0) digits[d++] = static_cast<char>('0' + n % 10), n /= 10;
        while (d > 0) name[len++] = digits[--d];
      }
    s[count - 1][0] = 'g';
    return s;
  }();
  static constexpr auto names = [] {
    std::array<std::string_view, count> v{};
    for (int k = 0; k < count; ++k) v[k] = std::string_view(storage[k].data());
    return v;
  }();
};

// Default parameters: identical links of mass m, length l, slender-rod inertia m l²/12, hinge
// damping c; g = 9.81.
template <int N> constexpr std::array<double, 4 * N + 1> uniform(double m, double l, double c) {
  std::array<double, 4 * N + 1> v{};
  for (int i = 0; i < N; ++i) {
    v[i] = m;
    v[N + i] = l;
    v[2 * N + i] = m * l * l / 12.0;
    v[3 * N + i] = c;
  }
  v[4 * N] = 9.81;
  return v;
}

// Mass centres and orientations of N links (parameters laid out as in Names<N>).
template <int N, class S> void bodies(In<S> q, In<S> p, Out<PlanarBody<S>> b) {
  using std::cos, std::sin;
  S jx(0), jy(0);  // current joint
  for (int i = 0; i < N; ++i) {
    const S& l = p[N + i];
    const S c = cos(q[i]), s = sin(q[i]);
    b[i].mass = p[i];
    b[i].inertia = p[2 * N + i];
    b[i].x = jx + 0.5 * l * c;
    b[i].y = jy + 0.5 * l * s;
    b[i].angle = q[i];
    jx = jx + l * c;
    jy = jy + l * s;
  }
}

// V = Σ mᵢ g yᵢ.
template <int N, class S> S gravity_potential(In<S> q, In<S> p) {
  using std::sin;
  S V(0), jy(0);
  const S& g = p[4 * N];
  for (int i = 0; i < N; ++i) {
    const S& l = p[N + i];
    const S s = sin(q[i]);
    V = V + p[i] * g * (jy + 0.5 * l * s);
    jy = jy + l * s;
  }
  return V;
}

// Hinge damping, as described at the top of this file.
template <int N, class S> void hinge_damping(In<S> qd, In<S> p, Out<S> Q) {
  for (int i = 0; i < N; ++i) {
    const S previous = i > 0 ? qd[i - 1] : S(0);
    Q[i] = -p[3 * N + i] * (qd[i] - previous);
    if (i + 1 < N) Q[i] = Q[i] + p[3 * N + i + 1] * (qd[i + 1] - qd[i]);
  }
}

template <int N> struct CoordinateNames {
  static_assert(N < 10000, "chain_detail::CoordinateNames: at most 4 digits");
  static constexpr auto storage = [] {
    std::array<std::array<char, 12>, N> s{};  // "theta" + 4 digits + NUL
    for (int i = 0; i < N; ++i) {
      int n = i + 1, len = 5, d = 0;
      s[i][0] = 't', s[i][1] = 'h', s[i][2] = 'e', s[i][3] = 't', s[i][4] = 'a';
      char digits[4]{};
      while (n > 0) digits[d++] = static_cast<char>('0' + n % 10), n /= 10;
      while (d > 0) s[i][len++] = digits[--d];
    }
    return s;
  }();
  static constexpr auto names = [] {
    std::array<std::string_view, N> v{};
    for (int i = 0; i < N; ++i) v[i] = std::string_view(storage[i].data());
    return v;
  }();
};

}  // namespace chain_detail

// An open planar chain of N links pinned at the origin, with hinge damping. Defaults: the
// paper's inflated beam links (0.01 kg, 0.5 m) and hinge damping 4e-3 N·m·s.
template <int N> struct Chain {
  static_assert(N >= 1 && N <= 999, "Chain<N>: N must be between 1 and 999");
  static constexpr auto coordinates = chain_detail::CoordinateNames<N>::names;
  static constexpr auto parameters = chain_detail::Names<N>::names;
  static constexpr auto parameter_values = chain_detail::uniform<N>(0.01, 0.5, 4e-3);
  static constexpr int body_count = N;

  template <class S> static void bodies(In<S> q, In<S> p, Out<PlanarBody<S>> b) {
    chain_detail::bodies<N, S>(q, p, b);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    return chain_detail::gravity_potential<N, S>(q, p);
  }
  template <class S>
  static void generalized_forces(const S&, In<S>, In<S> qd, In<S>, In<S> p, Out<S> Q) {
    chain_detail::hinge_damping<N, S>(qd, p, Q);
  }
};

// The same chain without dampers: a natural (conservative) system, for energy tests.
template <int N> struct UndampedChain {
  static constexpr auto coordinates = chain_detail::CoordinateNames<N>::names;
  static constexpr auto parameters = chain_detail::Names<N>::names;
  static constexpr auto parameter_values = chain_detail::uniform<N>(1.0, 1.0, 0.0);
  static constexpr int body_count = N;

  template <class S> static void bodies(In<S> q, In<S> p, Out<PlanarBody<S>> b) {
    chain_detail::bodies<N, S>(q, p, b);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    return chain_detail::gravity_potential<N, S>(q, p);
  }
};

// The paper's closed chain: five links of 2 kg and 1 m between the pin at the origin and a second
// ground pin at (dx, dy); φ = (Σ lᵢ cos θᵢ − dx, Σ lᵢ sin θᵢ − dy) closes the loop. A drive torque
// τ sin(Ω t) acts on link 1 (against the ground), the hinges are damped (including the closing
// hinge 6 between link 5 and the ground, coefficient c6 = c5's value by default).
struct ClosedChain5 {
  static constexpr int N = 5;
  static constexpr auto coordinates = chain_detail::CoordinateNames<N>::names;
  static constexpr std::array parameters{"m1", "m2", "m3", "m4", "m5", "l1", "l2", "l3", "l4", "l5",
                                         "I1", "I2", "I3", "I4", "I5", "c1", "c2", "c3", "c4", "c5",
                                         "g",  "dx", "dy", "c6", "tau", "Omega"};
  static constexpr std::array<double, 26> parameter_values = [] {
    std::array<double, 26> v{};
    const auto chain = chain_detail::uniform<N>(2.0, 1.0, 0.5);
    for (int i = 0; i < 21; ++i) v[i] = chain[i];
    v[21] = 1.0 + std::numbers::sqrt3;  // closes the rest shape below
    v[22] = 0.0;
    v[23] = 0.5;           // c6
    v[24] = 20.0;          // τ [N·m]
    v[25] = 2.0;           // Ω [rad/s]
    return v;
  }();
  static constexpr std::array constraint_names{"close_x", "close_y"};
  static constexpr int body_count = N;

  // Rest shape: a symmetric arch θ = (90°, 30°, 0°, −30°, −90°), which closes on the ground
  // pins (0, 0) and (1 + √3, 0) for unit links.
  static constexpr std::array<double, N> initial_q{std::numbers::pi / 2, std::numbers::pi / 6, 0.0,
                                                   -std::numbers::pi / 6, -std::numbers::pi / 2};

  template <class S> static void bodies(In<S> q, In<S> p, Out<PlanarBody<S>> b) {
    chain_detail::bodies<N, S>(q, p, b);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    return chain_detail::gravity_potential<N, S>(q, p);
  }
  template <class S> static void constraints(In<S> q, In<S> p, Out<S> phi) {
    using std::cos, std::sin;
    S x(0), y(0);
    for (int i = 0; i < N; ++i) {
      x = x + p[N + i] * cos(q[i]);
      y = y + p[N + i] * sin(q[i]);
    }
    phi[0] = x - p[21];
    phi[1] = y - p[22];
  }
  template <class S>
  static void generalized_forces(const S& t, In<S>, In<S> qd, In<S>, In<S> p, Out<S> Q) {
    using std::sin;
    chain_detail::hinge_damping<N, S>(qd, p, Q);
    Q[N - 1] = Q[N - 1] - p[23] * qd[N - 1];  // closing hinge: link 5 against the ground
    Q[0] = Q[0] + p[24] * sin(p[25] * t);
  }
};

}  // namespace eom::models
