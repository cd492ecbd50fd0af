// MJCF import: a MuJoCo model file compiled by MuJoCo's own compiler (mj_loadXML → mjModel) and
// written as a model header in the tree form (eom/multibody/tree.hpp), so that a MuJoCo model goes
// through the same tracer and generator as every other. Only this library and the eomgen-mjcf
// command link MuJoCo; the header it writes, the kernels and the runtime do not.
//
// Conventions (docs/CONTRACT.md §1, MJCF; README "MJCF import"):
//   - q, v are MuJoCo's qpos, qvel: free joints (the first joint's makes the floating base) and
//     ball joints as eom/model/free_joint.hpp (MuJoCo's own convention; `quaternions` lists
//     where they are), hinges and slides one each, in MuJoCo's order;
//   - each body's frame is MuJoCo's: parent · (pos, quat) · for each of its joints in order
//     T(anchor) · rotation(axis, q − ref) · T(−anchor) (hinge), T(axis (q − ref)) (slide) or
//     T(anchor) · rotation(quaternion) · T(−anchor) (ball); a
//     body with several joints, or one whose anchor is off its origin, becomes a chain of links
//     (massless but the last), which is exact;
//   - inputs: MuJoCo's ctrl, one per actuator; Q = Σ gear · force(ctrl) on the actuated joints
//     (gain and affine bias, ctrlrange and forcerange clamps) − damping · v − stiffness · (q −
//     springref); armature on M's diagonal (TreeLink::armature); gravity from <option gravity>;
//     fixed tendons: their spring-dampers and actuators act through Jᵀ, J their coefficients
//     (their limits and friction loss: the scene's `tendons`, rows of the contact step);
//   - equality constraints (connect, weld, joint) as the model's constraints φ(q) = 0, row for row
//     MuJoCo's (held exactly; MuJoCo's solver holds them softly);
//   - the scene as data (eom/multibody/scene.hpp): geoms, joint limits, friction loss, the
//     equalities' softness, the fixed tendons, <option>, qpos0, keyframes;
//   - refused, with the element's kind, name and why: a free joint sharing its body, armature or
//     stiffness on a free or ball joint, a limited ball joint, spatial tendons, a fixed tendon
//     over a ball or free joint, tendon equalities, actuators with activation dynamics or a transmission other than a hinge or
//     slide joint or a fixed tendon,
//     muscle and user gains or biases, fluid forces (density, viscosity), a number MuJoCo
//     compiles non-finite (its field named). Contacts, joint limits and friction loss are
//     MuJoCo's constraint solver's: not part of the model (as MuJoCo with mjDSBL_CONSTRAINT).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace eom::mjcf {

// Every problem with a file: "<file>: <MuJoCo's message>" (with its line) or
// "<file>:<line>: <kind> '<name>': <why>" (the line where the element is in <file> itself).
class MjcfError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct HeaderOptions {
  std::string class_name;  // the model struct; default: the model's name made an identifier
  std::string ns = "eom::mjcf_models";  // its namespace
};

// Loads `path` with MuJoCo's compiler and writes the model header (the text). Throws MjcfError
// naming the file (and MuJoCo's line, where MuJoCo gives one) or the element refused. What the
// model leaves out but a user should know (friction loss, joint limits) goes to `warnings`.
std::string model_header(const std::string& path, const HeaderOptions& options = {},
                         std::vector<std::string>* warnings = nullptr);

// The files MuJoCo reads for `path`: the file and, recursively, those its <include>s name
// (relative to the model file's folder, as MuJoCo resolves them), absolute; for the build's
// dependencies. Files a model names but does not include (meshes, textures) are not listed.
std::vector<std::string> files_read(const std::string& path);

}  // namespace eom::mjcf
