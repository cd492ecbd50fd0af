// A model that yields NaN at its default parameters: the spring's rest length is log(−1).
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

struct NanAtDefaults {
  static constexpr std::array coordinates{"x"};
  static constexpr std::array parameters{"k", "a"};
  static constexpr std::array parameter_values{1.0, -1.0};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) {
    return 0.5 * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::log;
    const S stretch = q[0] - log(p[1]);
    return 0.5 * p[0] * stretch * stretch;
  }
};
