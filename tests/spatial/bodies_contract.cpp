// Compile-time contract of the body form, one case per EOM_CASE (tests/spatial/CMakeLists.txt
// checks the compiler's message). EOM_CASE 0 is valid and must compile silently.
//   1: `bodies` writes plain scalars instead of eom::SpatialBody<S> (or eom::PlanarBody<S>).
//   2: `bodies` without `body_count`.
#include <array>

#include <eom/reference/reference.hpp>

struct Model {
  static constexpr std::array coordinates{"x"};
#if EOM_CASE != 2
  static constexpr int body_count = 1;
#endif
#if EOM_CASE == 1
  template <class S> static void bodies(eom::In<S> q, eom::In<S>, eom::Out<S> b) { b[0] = q[0]; }
#else
  template <class S>
  static void bodies(eom::In<S> q, eom::In<S>, eom::Out<eom::SpatialBody<S>> b) {
    b[0].mass = S(1);
    b[0].position = {q[0], S(0), S(0)};
    b[0].rotation = {S(1), S(0), S(0), S(0), S(1), S(0), S(0), S(0), S(1)};
  }
#endif
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) { return q[0] * q[0]; }
};

int main() { return eom::Reference<Model>::nq == 1 ? 0 : 1; }
