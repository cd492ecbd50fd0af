// A planar chain of N equal point masses on massless links, in absolute angles from the
// horizontal (the paper's chain examples): M is dense, so it exercises every graph pass at scale.
#pragma once

#include <array>
#include <cmath>
#include <string_view>

#include <eom/model/model.hpp>

namespace eomtest {

template <int N> struct ChainModel {
  // coordinate names t000, t001, ...
  static constexpr std::array<char, 5 * 128> storage = [] {
    std::array<char, 5 * 128> s{};
    for (int i = 0; i < 128; ++i) {
      s[5 * i] = 't';
      s[5 * i + 1] = static_cast<char>('0' + i / 100);
      s[5 * i + 2] = static_cast<char>('0' + i / 10 % 10);
      s[5 * i + 3] = static_cast<char>('0' + i % 10);
    }
    return s;
  }();

  static constexpr std::array<std::string_view, 128> names = [] {
    std::array<std::string_view, 128> a{};
    for (int i = 0; i < 128; ++i) a[i] = std::string_view(storage.data() + 5 * i, 4);
    return a;
  }();
  static constexpr std::array<std::string_view, N> coordinates = [] {
    std::array<std::string_view, N> a{};
    for (int i = 0; i < N; ++i) a[i] = names[i];
    return a;
  }();
  static constexpr std::array parameters{"m", "l", "g"};
  static constexpr std::array parameter_values{0.01, 0.5, 9.81};
  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    using std::cos, std::sin;
    S vx = 0.0, vy = 0.0, T = 0.0;
    for (int i = 0; i < N; ++i) {
      vx -= p[1] * sin(q[i]) * qd[i];
      vy += p[1] * cos(q[i]) * qd[i];
      T += 0.5 * p[0] * (vx * vx + vy * vy);
    }
    return T;
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::sin;
    S y = 0.0, V = 0.0;
    for (int i = 0; i < N; ++i) {
      y += p[1] * sin(q[i]);
      V += p[0] * p[2] * y;
    }
    return V;
  }
};

}  // namespace eomtest
