// What a simulation with contact needs beyond the equations of motion, carried by a model as
// constexpr data (docs/CONTRACT.md §1, "MJCF: the scene as data"): the collision geometry on its
// links, the joints' limits and friction loss with their constraint-solver parameters, the
// solver's options and where to start (qpos0, the keyframes). An MJCF model's header states them
// with MuJoCo's compiled numbers (and MuJoCo's enumerations' values), so that a consumer needs
// neither MuJoCo nor the file; a URDF robot's header with add_eom_model's GROUND or
// COLLISION_PAIRS states its <collision> geoms, pairs, limits and damping with MuJoCo's defaults
// (docs/CONTRACT.md §1, "URDF: the scene"). The dynamics do not use any of it.
#pragma once

#include <array>

namespace eom {

// A geom's shape, numbered as MuJoCo's mjtGeom.
enum class Shape { plane = 0, hfield, sphere, capsule, ellipsoid, cylinder, box, mesh };

// MuJoCo's soft-constraint parameters: solref (time constant, damping ratio, or −stiffness,
// −damping) and solimp (d0, d_width, width, midpoint, power).
struct Softness {
  std::array<double, 2> solref{0.02, 1.0};
  std::array<double, 5> solimp{0.9, 0.95, 0.001, 0.5, 2.0};
};

// A collision geom, fixed to a tree link (−1: the world) at `rotation` (column-major, geom axes →
// link axes) and `position` in that link's frame. size: MuJoCo's geom_size (sphere: radius;
// capsule, cylinder: radius, half-length; box, ellipsoid: half-sizes; plane: half-sizes for
// display, infinite for contact); a mesh or height field carries its kind only, not its data.
struct Geom {
  const char* name = "";  // "" where unnamed
  Shape shape = Shape::sphere;
  int link = -1;
  std::array<double, 3> size{0, 0, 0};
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> position{0, 0, 0};
  std::array<double, 3> friction{1.0, 0.005, 0.0001};  // sliding, torsional, rolling
  int condim = 3, contype = 1, conaffinity = 1, priority = 0;
  double solmix = 1.0, margin = 0.0, gap = 0.0;
  Softness softness;
  double rbound = 0.0;  // the radius of a sphere about its centre that holds it (0: a plane)
};

// A pair of geoms that may touch, as MuJoCo's collision pipeline decides at build time (its
// contype/conaffinity test, its filters of bodies welded together and of parent and child, its
// <exclude>s, its <pair>s), geom1's shape not after geom2's (MuJoCo's order), with the contact
// parameters MuJoCo mixes from the two geoms (or a <pair> states): condim, friction (tangent 1,
// tangent 2, torsional, rolling 1, rolling 2; at least MuJoCo's mjMINMU), margin, gap, softness,
// the <option> override applied where enabled. Listed in the order MuJoCo tests them.
// inverse_weight: the two bodies' translational and rotational inverse inertias at qpos0 summed
// (MuJoCo's body_invweight0), which scale the rows' regularization.
struct CollisionPair {
  int geom1 = 0, geom2 = 0;
  int condim = 3;
  std::array<double, 5> friction{1.0, 1.0, 0.005, 0.0001, 0.0001};
  double margin = 0.0, gap = 0.0;
  Softness softness;
  std::array<double, 2> inverse_weight{0.0, 0.0};
};

// A limited joint: its coordinate (q index), velocity (v index), range, margin, softness. A free
// joint is never limited; a ball joint's range bounds its rotation angle (MuJoCo's convention).
// inverse_weight: MuJoCo's dof_invweight0 of its velocity (scales the rows' regularization).
struct JointLimit {
  const char* joint = "";
  int coordinate = 0, velocity = 0;
  double lower = 0, upper = 0, margin = 0;
  Softness softness;
  double inverse_weight = 0;
};

// Dry friction on one velocity: the largest force it resists with, and its softness.
struct FrictionLoss {
  int velocity = 0;
  double loss = 0;
  Softness softness;
  double inverse_weight = 0;  // MuJoCo's dof_invweight0
};

// A fixed tendon (MJCF <fixed>): its length is Σ coef · q over its joints (the first `count` of
// `joints`; N, the scene's most in one tendon), its Jacobian row the coefficients (summed where a
// velocity comes twice). Its stiffness, damping and actuators are the dynamics' (generalized
// forces); the constraint solver holds its limit (lower ≤ length ≤ upper, rows within margin) and
// friction loss, with MuJoCo's tendon_invweight0.
struct TendonJoint {
  int coordinate = 0, velocity = 0;
  double coef = 0;
};
template <int N> struct FixedTendon {
  const char* name = "";  // "" where unnamed
  int count = 0;
  std::array<TendonJoint, N> joints{};
  bool limited = false;
  double lower = 0, upper = 0, margin = 0;
  Softness softness;  // the limit's
  double frictionloss = 0;
  Softness friction_softness;
  double inverse_weight = 0;
};

// An equality constraint's rows in the model's constraints (φ[first, first + rows)) and the
// softness MuJoCo's solver holds it with; the model itself holds it exactly, eom::contact_step
// softly as MuJoCo. inverse_weight: what scales its rows' regularization (MuJoCo's
// efc_diagApprox: the two bodies' translational body_invweight0 summed for a connect or weld,
// every row of a weld alike as MuJoCo 2.2 has it; the joints' dof_invweight0 summed for a joint
// equality); torquescale: a weld's scale of its rotation rows' Jacobian (1 otherwise).
struct EqualitySoftness {
  const char* name = "";
  int first = 0, rows = 0;
  Softness softness;
  double inverse_weight = 0, torquescale = 1;
};

// The solver and integrator options (MuJoCo's <option>): enumerations as MuJoCo numbers them
// (integrator: 0 Euler, 1 RK4, 2 implicit; cone: 0 pyramidal, 1 elliptic; solver: 0 PGS, 1 CG,
// 2 Newton); disable_flags and enable_flags are MuJoCo's mjtDisableBit and mjtEnableBit bits.
struct SolverOptions {
  double timestep = 0.002, impratio = 1.0, tolerance = 1e-8;
  int iterations = 100, noslip_iterations = 0;
  double noslip_tolerance = 1e-6;
  int integrator = 0, cone = 0, solver = 2;
  int disable_flags = 0, enable_flags = 0;
  double override_margin = 0;  // with enable_flags' override bit: every contact's margin and
  Softness override_softness;  // softness
};

// A keyframe: a named state (and control) to start from.
template <int nq, int nv, int nu> struct Keyframe {
  const char* name = "";
  double time = 0;
  std::array<double, nq> qpos{};
  std::array<double, nv> qvel{};
  std::array<double, nu> ctrl{};
};

}  // namespace eom
