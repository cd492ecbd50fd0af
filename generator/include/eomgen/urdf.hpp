// URDF import: a robot description file read into plain data, checked, and written out as a model
// header in the spatial body form (eom::SpatialBody), so that a URDF robot goes through the same
// tracer and generator path as every hand-written model.
//
// Conventions (README "URDF import" states them for users):
//   - coordinates: the non-fixed joints (revolute, continuous, prismatic) in file order, but for
//     <mimic> joints, which move by multiplier · q_leader + offset (docs/CONTRACT.md §1, URDF);
//   - child frame = parent frame · T(origin xyz, rpy) · motion(q), rpy = Rz(yaw)·Ry(pitch)·Rx(roll),
//     motion a rotation by q about the (normalized) axis or a translation by q along it;
//   - a link's inertial: mass, mass centre at the inertial origin xyz (link frame), inertia tensor
//     about the mass centre in the frame rotated by the inertial origin's rpy; no <inertial>:
//     massless; links joined by fixed joints are merged into the nearest moving ancestor;
//   - the root link (no joint's child) is fixed to the world; gravity g = 9.81 along −z of it;
//   - inputs: one per coordinate, Q = u − d⊙q̇ − f⊙tanh(q̇ / friction_smoothing) with d, f the
//     joint's <dynamics damping, friction> (a mimic joint's times its multiplier on its leader's);
//   - <limit>: data in the header (position_lower/upper, effort_limit, velocity_limit).
#pragma once

#include <array>
#include <limits>
#include <optional>
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

// A <collision> element (read only where ReadOptions::collisions asks): its shape, sizes as the
// file writes them, its placement in the link frame and its line (for messages). The shapes
// eom::Shape collides: box (size: full edge lengths), sphere (radius), capsule (radius, length of
// the cylindrical part between the two cap centres, along the z axis: the <capsule> of urdfdom and
// sdformat), cylinder (radius, length along z; it collides with the ground only); any other (mesh)
// is kept as `unsupported`, named in `shape`, and skipped by the scene with a warning
// (docs/CONTRACT.md §1, "URDF: the scene").
struct Collision {
  enum class Kind { box, sphere, capsule, unsupported, cylinder };
  std::string shape;                    // unsupported: the element's name (mesh, ...)
  std::string name;                     // <collision name>, "" when absent
  Kind kind = Kind::sphere;
  std::array<double, 3> size{0, 0, 0};  // box: x y z; sphere: radius; capsule, cylinder: radius,
                                        // length
  Pose origin;
  int line = 0;
};

struct Link {
  std::string name;
  bool has_inertial = false;            // false: massless
  Inertial inertial;
  std::vector<Collision> collisions;    // file order; empty unless ReadOptions::collisions
  int line = 0;                         // of its <link>
};

enum class JointType { revolute, continuous, prismatic, fixed, floating };

struct Joint {
  std::string name;
  JointType type = JointType::fixed;
  std::string parent, child;            // link names
  Pose origin;                          // child joint frame in the parent link frame
  std::array<double, 3> axis{1, 0, 0};  // as written (normalized where it is used)
  double damping = 0;                   // <dynamics damping>, 0 when absent
  double friction = 0;                  // <dynamics friction>, 0 when absent
  // <limit>: ±inf where an attribute is absent (lower and upper too: the URDF default 0 would
  // lock the joint), and for a continuous joint's position. A leader's position and velocity
  // limits are narrowed by its mimics' (those within which every joint it moves keeps its own).
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  double effort = std::numeric_limits<double>::infinity();
  double velocity = std::numeric_limits<double>::infinity();
  // <mimic joint multiplier offset>: this joint has no coordinate; its position is
  // multiplier · q_leader + offset. Resolved: `leader` is a joint with a coordinate of its own
  // (a chain a → b → c is composed), as written in `written_leader`.
  struct Mimic {
    std::string leader, written_leader;
    double multiplier = 1, offset = 0;
  };
  std::optional<Mimic> mimic;
};

// What to do with a moving link whose inertia is not physically consistent (a principal moment
// negative, or one larger than the sum of the other two): refuse it (error), take it as written
// with a warning (warn), or replace it by the nearest consistent one with a warning saying by
// how much (nearest: principal moments clamped to ≥ 0 and to the triangle inequality).
enum class InertiaPolicy { error, warn, nearest };

// The file as written, validated: every name exists, one root, a tree (no loops, every link but
// the root is the child of exactly one joint), supported joint types, non-zero axes, masses ≥ 0,
// physically consistent inertias (ReadOptions::inertia; a link welded to a fixed root only warns),
// mimics resolved (Joint::mimic). A floating joint (at most one) must join a massless root link
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
  // What the reader let through but a user should know ("<file>:<line>: link 'x': ..."): a
  // welded link's inconsistent inertia, an inertia taken or corrected under InertiaPolicy, a
  // <mimic> on a fixed joint. eomgen-urdf prints them on stderr.
  std::vector<std::string> warnings;
  // A moving link's inconsistent inertia was accepted (InertiaPolicy::warn): the model header
  // says so (inconsistent_inertia_accepted), so that the generator's and eom::Reference's body
  // checks let it through.
  bool inconsistent_inertia = false;
  // The <collision> elements were read (ReadOptions::collisions): model_header can write a scene.
  bool collisions_read = false;
};

// The speed ε of the smoothed Coulomb friction the model header writes for a joint's
// <dynamics friction="f">: τ = −f·tanh(q̇ / ε), within 1 % of −f·sign(q̇) for |q̇| > 2.65 ε. It is
// the parameter friction_smoothing (rad/s or m/s), so a user can change it.
inline constexpr double friction_smoothing = 0.01;

struct ReadOptions {
  bool free_root = false;  // add_eom_model's FLOATING_BASE: free the root link of a file that has
                           // no floating joint (with one, it is an error)
  InertiaPolicy inertia = InertiaPolicy::error;  // for links that move
  // Read every link's <collision> elements (Link::collisions), for a scene (HeaderOptions::ground,
  // collision_pairs): a malformed one is an error naming the file, line and link; a shape other
  // than box, sphere, capsule and cylinder a warning (Robot::warnings), and the scene leaves it
  // out. Off:
  // <collision> is not looked at (the model header does not use it).
  bool collisions = false;
};

// Reads and validates a URDF file (tinyxml2); throws UrdfError naming the file, the joint or link,
// and the problem.
Robot read(const std::string& path, const ReadOptions& options);
Robot read(const std::string& path, bool free_root = false);
// The same from text already in memory (`file` names it in messages).
Robot parse(const std::string& text, const std::string& file, const ReadOptions& options);
Robot parse(const std::string& text, const std::string& file, bool free_root = false);

struct HeaderOptions {
  std::string class_name;                // the model struct; default: the robot's name made an identifier
  std::string ns = "eom::urdf_models";   // its namespace
  // The scene for simulation with contact (eom/multibody/scene.hpp, eom::contact_step; add_eom_model's
  // GROUND and COLLISION_PAIRS, docs/CONTRACT.md §1 "URDF: the scene"): with either given, the
  // header also states the links' <collision> geoms (the robot read with ReadOptions::collisions),
  // the candidate pairs, the joints' <limit>s as MuJoCo limits, <dynamics damping> as MuJoCo's
  // damping, and MuJoCo's default contact parameters and solver options. Neither: no scene, the
  // header as without these options.
  std::optional<double> ground;          // a plane z = height (world axes) against every moving geom
  std::vector<std::string> collision_pairs;  // "<linkA>:<linkB>": every geom of A against every geom of B
};

// The robot as a model header in the spatial body form: coordinates (the moving joints, file
// order), inputs (one per coordinate), parameters (g, then per link with mass: <link>_mass,
// <link>_com_x/y/z, <link>_Ixx/Iyy/Izz/Ixy/Ixz/Iyz, then <joint>_damping for damped joints,
// <joint>_friction for joints with friction, and friction_smoothing if any), the limits arrays, one
// SpatialBody per link with mass that moves (fixed-joint children ride on their parent's frame).
// Throws UrdfError when no link that moves has mass, or names collide as identifiers. A
// COLLISION_PAIRS pair of geoms eom::collide does not model (a cylinder against anything but the
// ground) is left out with a warning in `warnings` ("<file>:<line>: link 'x': ...") where given.
std::string model_header(const Robot& robot, const HeaderOptions& options = {},
                         std::vector<std::string>* warnings = nullptr);

// `name` as a C++ identifier: other characters become '_', a leading digit gets `prefix` before it.
std::string identifier(const std::string& name, const std::string& prefix);

}  // namespace eom::urdf
