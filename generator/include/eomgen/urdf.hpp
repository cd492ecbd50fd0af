// URDF import: a robot description file read into plain data, checked, and written out as a model
// header in the spatial body form (eom::SpatialBody), so that a URDF robot goes through the same
// tracer and generator path as every hand-written model.
//
// Conventions (README "URDF import" states them for users):
//   - coordinates: the non-fixed joints (revolute, continuous, prismatic) in file order;
//   - child frame = parent frame · T(origin xyz, rpy) · motion(q), rpy = Rz(yaw)·Ry(pitch)·Rx(roll),
//     motion a rotation by q about the (normalized) axis or a translation by q along it;
//   - a link's inertial: mass, mass centre at the inertial origin xyz (link frame), inertia tensor
//     about the mass centre in the frame rotated by the inertial origin's rpy; no <inertial>:
//     massless; links joined by fixed joints are merged into the nearest moving ancestor;
//   - the root link (no joint's child) is fixed to the world; gravity g = 9.81 along −z of it;
//   - inputs: one per coordinate, Q = u − d⊙q̇ with d the joint's <dynamics damping>.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace eom::urdf {

// Every problem with a file: "<file>: <joint or link '<name>'>: <problem>".
class UrdfError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Pose {
  std::array<double, 3> xyz{0, 0, 0};
  std::array<double, 3> rpy{0, 0, 0};
};

struct Inertial {
  double mass = 0;
  Pose origin;                          // mass centre and inertia axes in the link frame
  std::array<double, 6> inertia{};      // ixx iyy izz ixy ixz iyz (tensor entries)
};

struct Link {
  std::string name;
  bool has_inertial = false;            // false: massless
  Inertial inertial;
};

enum class JointType { revolute, continuous, prismatic, fixed, floating };

struct Joint {
  std::string name;
  JointType type = JointType::fixed;
  std::string parent, child;            // link names
  Pose origin;                          // child joint frame in the parent link frame
  std::array<double, 3> axis{1, 0, 0};  // as written (normalized where it is used)
  double damping = 0;                   // <dynamics damping>, 0 when absent
};

// The file as written, validated: every name exists, one root, a tree (no loops, every link but
// the root is the child of exactly one joint), supported joint types, non-zero axes, masses ≥ 0,
// physically consistent inertias. A floating joint (at most one) must join a massless root link
// (conventionally `world`) with nothing else attached to its child, at the identity origin:
// that root and joint are dropped and the child becomes the root, with `floating` set.
struct Robot {
  std::string name;                     // <robot name>
  std::string file;                     // where it was read from (for messages)
  std::vector<Link> links;              // file order
  std::vector<Joint> joints;            // file order
  std::string root;                     // the link that is no joint's child
  // The root link flies free (docs/CONTRACT.md §1, the free joint): its frame is placed by
  // q[0..7) = (x, y, z, qw, qx, qy, qz) and moves with v[0..6) = (world velocity of its origin,
  // angular velocity in its own axes); false: the root is fixed to the world.
  bool floating = false;
};

// Reads and validates a URDF file (tinyxml2); throws UrdfError naming the file, the joint or link,
// and the problem. free_root (add_eom_model's FLOATING_BASE) frees the root link of a file that
// has no floating joint; with one, it is an error.
Robot read(const std::string& path, bool free_root = false);
// The same from text already in memory (`file` names it in messages).
Robot parse(const std::string& text, const std::string& file, bool free_root = false);

struct HeaderOptions {
  std::string class_name;                // the model struct; default: the robot's name made an identifier
  std::string ns = "eom::urdf_models";   // its namespace
};

// The robot as a model header in the spatial body form: coordinates (the moving joints, file
// order), inputs (one per coordinate), parameters (g, then per link with mass: <link>_mass,
// <link>_com_x/y/z, <link>_Ixx/Iyy/Izz/Ixy/Ixz/Iyz, then <joint>_damping for damped joints), one
// SpatialBody per link with mass that moves (fixed-joint children ride on their parent's frame).
// Throws UrdfError when no link that moves has mass, or names collide as identifiers.
std::string model_header(const Robot& robot, const HeaderOptions& options = {});

// `name` as a C++ identifier: other characters become '_', a leading digit gets `prefix` before it.
std::string identifier(const std::string& name, const std::string& prefix);

}  // namespace eom::urdf
