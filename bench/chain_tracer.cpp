// The tracer of eom::models::Chain<N> for the generator scaling study (bench/scaling.py): the
// program add_eom_model() would build for one N, compiled once for every N of the study.
//
//   eom_chain_tracer <N> <tracer arguments ...>     (--name, --out-dir, --kernel, ...)
//   eom_chain_tracer --sizes                        (the N it was compiled for)
#include <array>
#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <utility>

#include <eomgen/tracer.hpp>
#include <models/chain.hpp>

namespace {

// Chain<N> of models/chain.hpp, restated with room for the coordinate names of N >= 100: there
// each name has 8 chars, so "theta100" loses its terminating NUL and Chain<100> does not compile
// (reported; models/ is not ours to edit). The same functions (chain_detail), the same names,
// parameters and defaults as eom::models::Chain<N>.
template <int N> struct ScalingChain {
  static constexpr auto storage = [] {
    std::array<std::array<char, 12>, N> s{};
    for (int i = 0; i < N; ++i) {
      int len = 0;
      for (char c : std::string_view("theta")) s[i][len++] = c;
      char digits[4]{};
      int d = 0;
      for (int n = i + 1; n > 0; n /= 10) digits[d++] = static_cast<char>('0' + n % 10);
      while (d > 0) s[i][len++] = digits[--d];
    }
    return s;
  }();
  static constexpr auto coordinates = [] {
    std::array<std::string_view, N> v{};
    for (int i = 0; i < N; ++i) v[i] = std::string_view(storage[i].data());
    return v;
  }();
  static constexpr auto parameters = eom::models::chain_detail::Names<N>::names;
  static constexpr auto parameter_values = eom::models::chain_detail::uniform<N>(0.01, 0.5, 4e-3);
  static constexpr int body_count = N;

  template <class S>
  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::PlanarBody<S>> b) {
    eom::models::chain_detail::bodies<N, S>(q, p, b);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return eom::models::chain_detail::gravity_potential<N, S>(q, p);
  }
  template <class S>
  static void generalized_forces(const S&, eom::In<S>, eom::In<S> qd, eom::In<S>, eom::In<S> p,
                                 eom::Out<S> Q) {
    eom::models::chain_detail::hinge_damping<N, S>(qd, p, Q);
  }
};

// Drift guard: the restatement must keep Chain<N>'s parameters and defaults.
static_assert(ScalingChain<50>::parameter_values == eom::models::Chain<50>::parameter_values);
static_assert(ScalingChain<50>::parameters == eom::models::Chain<50>::parameters);
static_assert(ScalingChain<50>::coordinates == eom::models::Chain<50>::coordinates);

using Sizes = std::integer_sequence<int, 2, 3, 5, 7, 10, 15, 20, 30, 40, 50, 70, 100>;

template <int... n> void list(std::integer_sequence<int, n...>) {
  ((std::printf("%d ", n)), ...);
  std::printf("\n");
}

// tracer_main<Chain<n>> for the n that equals `links`; false when no compiled size matches.
template <int... n>
bool dispatch(std::integer_sequence<int, n...>, int links, int argc, char** argv, int& rc) {
  return ((links == n ? (rc = eom::gen::tracer_main<ScalingChain<n>>(argc, argv), true)
                      : false) ||
          ...);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::string_view(argv[1]) == "--sizes") {
    list(Sizes{});
    return 0;
  }
  const int links = argc >= 2 ? std::atoi(argv[1]) : 0;
  int rc = 1;
  // The tracer sees argv[0] followed by the arguments after N.
  if (argc >= 2) argv[1] = argv[0];
  if (argc < 2 || !dispatch(Sizes{}, links, argc - 1, argv + 1, rc)) {
    std::fprintf(stderr, "eom_chain_tracer: N must be one of: ");
    list(Sizes{});
    return 2;
  }
  return rc;
}
