// Models that break the contract, one per EOM_CASE. Each must fail to compile with a message
// that names the field or function at fault (tests/contract/CMakeLists.txt checks the text).
// EOM_CASE 0 is a valid model: it must compile, so the harness itself is known to work.
#include <array>

#include <eom/reference/reference.hpp>

using eom::In;
using eom::Out;

#if EOM_CASE == 12
// 1,000 parameter names (a 90-link URDF has as many), the last one a repeat of the first: the
// distinctness check must still finish within the compiler's constexpr limits and name the field.
namespace many {
constexpr int n = 1000;
constexpr auto storage = [] {
  std::array<std::array<char, 6>, n> s{};
  for (int i = 0; i < n; ++i) s[i] = {'p', char('0' + i / 100), char('0' + i / 10 % 10), char('0' + i % 10), 0, 0};
  s[n - 1] = s[0];
  return s;
}();
constexpr auto names = [] {
  std::array<const char*, n> a{};
  for (int i = 0; i < n; ++i) a[i] = storage[i].data();
  return a;
}();
}  // namespace many
#endif

struct Model {
#if EOM_CASE != 6
  static constexpr std::array coordinates{"x", "y"};
#endif
#if EOM_CASE == 12
  static constexpr auto parameters = many::names;
  static constexpr std::array<double, many::n> parameter_values{1.0, 2.0};
#elif EOM_CASE != 9
  static constexpr std::array parameters{"m", "k"};
#endif
#if EOM_CASE == 1
  static constexpr std::array parameter_values{1.0};  // one value for two names
#elif EOM_CASE != 8 && EOM_CASE != 12
  static constexpr std::array parameter_values{1.0, 2.0};
#endif
#if EOM_CASE == 2 || EOM_CASE == 10
  static constexpr std::array constraint_names{"c"};
#endif

#if EOM_CASE == 4
  template <class S> static S kinetic_energy(In<S> q, In<S> qd) { return q[0] * qd[0]; }
#else
  template <class S> static S kinetic_energy(In<S>, In<S> qd, In<S> p) {
    return 0.5 * p[0] * (qd[0] * qd[0] + qd[1] * qd[1]);
  }
#endif
#if EOM_CASE != 5
  template <class S> static S potential_energy(In<S> q, In<S> p) { return p[1] * q[0] * q[0]; }
#endif
#if EOM_CASE == 3
  template <class S> static void constraints(In<S> q, In<S>, Out<S> phi) { phi[0] = q[0] - q[1]; }
#elif EOM_CASE == 10
  template <class S> static void constraints(In<S> q, Out<S> phi) { phi[0] = q[0]; }  // no p
#endif
#if EOM_CASE == 11
  template <class S> static S generalized_forces(In<S> q, In<S>, In<S>, In<S>, Out<S>) { return q[0]; }
#endif
};

#if EOM_CASE == 7
struct Duplicate : Model {
  static constexpr std::array coordinates{"x", "x"};
};
using Checked = Duplicate;
#else
using Checked = Model;
#endif

int main() { return eom::Reference<Checked>::nq == 2 ? 0 : 1; }
