// eom_bench_frames: the task-space targets (issue "task space"), side by side in one binary, every
// kernel compiled with the same flags: the Panda's flange (models/robots/panda.urdf, panda_link8,
// every inertial parameter free) —
//   - generated frame_jacobian against the recursive implementation's (tests/support/
//     recursive_dynamics.hpp: forward kinematics of every body, then the joint columns) and
//     against eom::tree_frame_jacobian run in double (the templated recursion the generator
//     traces);
//   - generated frame_acceleration_bias against the recursive implementation's (kinematics, the
//     RNEA's outward pass) and eom::tree_frame_bias in double.
// Each pair is timed in alternating rounds (1000 calls per round, 201 rounds); the figure is the
// median of the per-round ratios, so that the machine's load changes both sides alike.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <bench_panda_frames.hpp>
#include <bench_panda_frames_model.hpp>

#include <eom/multibody/frames.hpp>
#include <eom/multibody/tree.hpp>

#include "paired_timing.hpp"
#include "recursive_dynamics.hpp"

using eombench::compare, eombench::sink;

int main() {
  namespace K = bench_panda_frames;
  using Model = eom::urdf_models::bench_panda_frames;
  constexpr int nq = K::nq, nv = K::nv;
  static_assert(K::nframes == 1);
  const auto robot = eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/panda.urdf");
  eomtest::RecursiveDynamics<double> rd(robot);
  const std::size_t flange = rd.link_of("panda_link8");
  const auto& p = K::parameter_values;
  const auto links = eom::tree_of<Model, double>(p);
  std::array<eom::LinkFrame<double>, eom::ModelInfo<Model>::nframes> at;
  Model::link_frames<double>(p, at);
  const auto name = std::find(eom::ModelInfo<Model>::frame_names.begin(),
                              eom::ModelInfo<Model>::frame_names.end(), "panda_link8");
  const eom::LinkFrame<double> frame = at[name - eom::ModelInfo<Model>::frame_names.begin()];

  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> x(-1, 1);
  constexpr int states = 64;
  std::vector<std::array<double, nq>> q(states);
  std::vector<std::array<double, nv>> v(states);
  for (int s = 0; s < states; ++s) {
    for (double& e : q[s]) e = 1.5 * x(rng);
    for (double& e : v[s]) e = 2 * x(rng);
  }
  std::array<double, 6 * nv> J;
  std::array<double, 6> a;
  std::printf("%-62s %11s %11s\n", "the Panda's flange (generated vs baseline)", "generated", "baseline");
  auto generated_J = [&](int i) {
    K::frame_jacobian(0, q[i % states].data(), p.data(), J.data());
    sink = J[0];
  };
  auto recursive_J = [&](int i) {
    rd.frame_jacobian(flange, q[i % states].data(), J.data());
    sink = J[0];
  };
  auto tree_J = [&](int i) {
    eom::tree_frame_jacobian<double>(links, frame, q[i % states], J);
    sink = J[0];
  };
  compare("frame_jacobian / recursive implementation (FK + columns)", generated_J, recursive_J);
  compare("frame_jacobian / eom::tree_frame_jacobian in double", generated_J, tree_J);
  auto generated_a = [&](int i) {
    K::frame_acceleration_bias(0, q[i % states].data(), v[i % states].data(), p.data(), a.data());
    sink = a[0];
  };
  auto recursive_a = [&](int i) {
    rd.frame_acceleration_bias(flange, q[i % states].data(), v[i % states].data(), a.data());
    sink = a[0];
  };
  auto tree_a = [&](int i) {
    eom::tree_frame_bias<double>(links, frame, q[i % states], v[i % states], a);
    sink = a[0];
  };
  compare("frame_acceleration_bias / recursive implementation", generated_a, recursive_a);
  compare("frame_acceleration_bias / eom::tree_frame_bias in double", generated_a, tree_a);
  std::array<double, 3> position;
  std::array<double, 9> rotation;
  auto generated_x = [&](int i) {
    K::frame_placement(0, q[i % states].data(), p.data(), position.data(), rotation.data());
    sink = position[0];
  };
  auto recursive_x = [&](int i) {
    rd.frame_placement(flange, q[i % states].data(), position.data(), rotation.data());
    sink = position[0];
  };
  compare("frame_placement / recursive implementation", generated_x, recursive_x);
}
