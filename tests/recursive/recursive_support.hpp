// Shared by the recursive-dynamics tests: Robot builders (the URDF parser is not used: robots are
// written in code), the robots themselves, scalar helpers and the error measure.
#pragma once

#include "recursive_dynamics.hpp"

#include <qd/dd_real.h>

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

namespace rtest {

using eom::urdf::Joint;
using eom::urdf::JointType;
using eom::urdf::Link;
using eom::urdf::Robot;
using P3 = std::array<double, 3>;
using Tensor = std::array<double, 6>;  // ixx iyy izz ixy ixz iyz

inline Link massless(std::string name) {
  Link l;
  l.name = std::move(name);
  return l;
}

inline Link body(std::string name, double mass, P3 xyz, P3 rpy, Tensor inertia) {
  Link l;
  l.name = std::move(name);
  l.has_inertial = true;
  l.inertial.mass = mass;
  l.inertial.origin.xyz = xyz;
  l.inertial.origin.rpy = rpy;
  l.inertial.inertia = inertia;
  return l;
}

inline Joint joint(std::string name, JointType type, std::string parent, std::string child, P3 xyz,
                   P3 rpy, P3 axis = {1, 0, 0}, double damping = 0) {
  Joint j;
  j.name = std::move(name);
  j.type = type;
  j.parent = std::move(parent);
  j.child = std::move(child);
  j.origin.xyz = xyz;
  j.origin.rpy = rpy;
  j.axis = axis;
  j.damping = damping;
  return j;
}

// The branched robot of test (c): 6 coordinates from 9 joints. Two branches leave the world (j1,
// and j7 behind the world-fixed pedestal); l1 carries two branches (j2 → fixed → prismatic j3 →
// j4, and j5); j4 is written before j3 (file order is not topological); tool is massless and
// fixed to l4; l2b is merged into l2. Axes off the coordinate directions and not normalized,
// non-zero rpy in every joint and inertial origin, non-diagonal inertia tensors, damping.
// Coordinates: j1 j2 j4 j3 j5 j7; λ = (−1, 0, 3, 1, 0, −1).
inline Robot branched_robot() {
  Robot r;
  r.name = "branched";
  r.root = "base";
  r.links = {
      body("base", 5.0, {0, 0, 0.1}, {0, 0, 0}, {0.1, 0.1, 0.1, 0, 0, 0}),
      body("l1", 2.0, {0.02, -0.01, 0.15}, {0.3, -0.2, 0.5}, {0.04, 0.05, 0.02, 0.003, -0.002, 0.001}),
      body("l2", 1.5, {0.12, 0.03, -0.02}, {-0.1, 0.4, 0.2}, {0.01, 0.03, 0.035, -0.002, 0.001, 0.0015}),
      body("l2b", 0.4, {0.05, -0.02, 0.01}, {0.6, 0.1, -0.7}, {0.002, 0.003, 0.004, 0.0002, -0.0001, 0.0003}),
      body("l3", 0.8, {-0.03, 0.08, 0.02}, {0.2, 0.2, -0.3}, {0.006, 0.004, 0.007, -0.0005, 0.0004, 0.0006}),
      body("l4", 0.5, {0.04, 0.0, -0.06}, {-0.5, 0.3, 0.1}, {0.003, 0.0025, 0.002, 0.0003, 0.0002, -0.0001}),
      body("l5", 1.1, {0.0, 0.1, 0.05}, {0.1, -0.6, 0.4}, {0.012, 0.009, 0.015, 0.001, 0.0007, -0.0012}),
      massless("tool"),
      body("pedestal", 3.0, {0, 0, 0}, {0, 0, 0}, {0.2, 0.2, 0.2, 0, 0, 0}),
      body("l6", 0.9, {0.07, -0.04, 0.09}, {0.25, 0.35, -0.45}, {0.008, 0.011, 0.006, -0.0007, 0.0009, 0.0004}),
  };
  r.joints = {
      joint("j1", JointType::revolute, "base", "l1", {0.05, -0.02, 0.3}, {0.1, -0.2, 0.3},
            {0.2, 0.3, 1.0}, 0.1),
      joint("j2", JointType::continuous, "l1", "l2", {0.1, 0.05, 0.2}, {-0.4, 0.25, 0.15},
            {1.0, -0.5, 0.2}, 0.05),
      joint("j4", JointType::revolute, "l3", "l4", {0.0, 0.2, -0.1}, {-0.2, 0.4, 0.6},
            {-0.6, 0.1, 0.8}, 0.03),
      joint("j2f", JointType::fixed, "l2", "l2b", {0.3, 0.0, 0.05}, {0.5, 0.2, -0.3}),
      joint("j3", JointType::prismatic, "l2b", "l3", {0.1, 0.1, 0.0}, {0.3, -0.1, 0.2},
            {0.3, 1.0, -0.4}, 0.5),
      joint("j5", JointType::revolute, "l1", "l5", {-0.1, 0.15, 0.1}, {0.7, 0.1, -0.5},
            {0.4, -0.9, 0.1}, 0.02),
      joint("tool_mount", JointType::fixed, "l4", "tool", {0.1, 0.0, 0.0}, {0.0, 0.3, 0.0}),
      joint("pedestal_mount", JointType::fixed, "base", "pedestal", {0.4, 0.3, 0.1}, {0.2, 0.0, 0.9}),
      joint("j7", JointType::revolute, "pedestal", "l6", {0.0, 0.0, 0.2}, {-0.3, 0.2, 0.1},
            {1.0, 1.0, 0.3}, 0.0),
  };
  return r;
}

// A planar double pendulum swinging about y: joint 2 at (0, 0, −l1) of link 1; mass centres at
// (0, 0, −a_k) of their links; q = 0 hangs down.
struct DoublePendulum {
  double m1 = 1.25, m2 = 0.75, l1 = 1.0, a1 = 0.5, a2 = 0.625, I1 = 0.0625, I2 = 0.03125;
  Robot robot() const {
    Robot r;
    r.root = "world";
    r.links = {massless("world"), body("arm1", m1, {0, 0, -a1}, {0, 0, 0}, {0.1, I1, 0.1, 0, 0, 0}),
               body("arm2", m2, {0, 0, -a2}, {0, 0, 0}, {0.05, I2, 0.05, 0, 0, 0})};
    r.joints = {joint("q1", JointType::revolute, "world", "arm1", {0, 0, 0}, {0, 0, 0}, {0, 1, 0}),
                joint("q2", JointType::revolute, "arm1", "arm2", {0, 0, -l1}, {0, 0, 0}, {0, 1, 0})};
    return r;
  }
};

template <class S>
double dbl(const S& x) {
  if constexpr (std::is_same_v<S, dd_real>)
    return to_double(x);
  else
    return static_cast<double>(x);
}

template <class S>
std::vector<S> convert(const std::vector<double>& x) {
  std::vector<S> r;
  for (const double v : x) r.push_back(S(v));
  return r;
}

// Normwise relative error in the max norm, computed in S: max|a − e| / max|e| (or max|a − e|
// when e = 0).
template <class S>
double normwise(const std::vector<S>& a, const std::vector<S>& e) {
  using std::abs;
  S num(0.0), den(0.0);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const S d = abs(a[i] - e[i]);
    if (d > num) num = d;
    if (abs(e[i]) > den) den = abs(e[i]);
  }
  if (!(num == num)) return HUGE_VAL;
  return den > S(0.0) ? dbl(num / den) : dbl(num);
}

// Reproducible states: q in [−2, 2], q̇ in [−1.5, 1.5] (the prismatic coordinate too: metres).
inline std::vector<double> uniform(std::mt19937& rng, int n, double half_width) {
  std::uniform_real_distribution<double> dist(-half_width, half_width);
  std::vector<double> x(static_cast<std::size_t>(n));
  for (auto& v : x) v = dist(rng);
  return x;
}

}  // namespace rtest
