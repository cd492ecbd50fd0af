// A Pinocchio model from what eomgen's URDF or MJCF reader read, for the benchmarks against Pinocchio
// (this install of Pinocchio has no URDF parser: it is built without urdfdom). The rules of
// bench_pinocchio.cpp's build_model for the arms, extended to a free root, to operational frames
// and to trees (that build_model adds a link's child joints in reverse order, which only chains
// tolerate): moving joints depth first in file order (RX/RY/RZ, PX/PY/PZ for principal axes, the
// unaligned joints otherwise), fixed joints merged into their parent body, as Pinocchio's own URDF
// parser does; a floating robot's root link gets a JointModelFreeFlyer ("root_joint"), and each
// link named in `frames` an OP_FRAME at its place in its body. tree_pinocchio_model: the same
// from a tree-form model header (an MJCF file read by eomgen-mjcf).
#pragma once

#include <pinocchio/multibody/model.hpp>

#include <algorithm>
#include <array>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <eom/multibody/tree.hpp>
#include <eomgen/urdf.hpp>

namespace eombench {

inline pinocchio::SE3 urdf_placement(const eom::urdf::Pose& pose) {
  // URDF: R = Rz(yaw) Ry(pitch) Rx(roll).
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(pose.rpy[2], Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pose.rpy[1], Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(pose.rpy[0], Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  return pinocchio::SE3(R, Eigen::Vector3d(pose.xyz[0], pose.xyz[1], pose.xyz[2]));
}

// One angle (or length) about (along) `axis`: RX/RY/RZ, PX/PY/PZ for principal axes.
inline pinocchio::JointModel axis_joint_model(const std::string& name,
                                              const std::array<double, 3>& axis, bool prismatic) {
  Eigen::Vector3d a(axis[0], axis[1], axis[2]);
  if (!(a.norm() > 0)) throw std::invalid_argument("joint " + name + ": zero axis");
  a.normalize();
  if (a == Eigen::Vector3d::UnitX())
    return prismatic ? pinocchio::JointModel(pinocchio::JointModelPX())
                     : pinocchio::JointModel(pinocchio::JointModelRX());
  if (a == Eigen::Vector3d::UnitY())
    return prismatic ? pinocchio::JointModel(pinocchio::JointModelPY())
                     : pinocchio::JointModel(pinocchio::JointModelRY());
  if (a == Eigen::Vector3d::UnitZ())
    return prismatic ? pinocchio::JointModel(pinocchio::JointModelPZ())
                     : pinocchio::JointModel(pinocchio::JointModelRZ());
  return prismatic ? pinocchio::JointModel(pinocchio::JointModelPrismaticUnaligned(a))
                   : pinocchio::JointModel(pinocchio::JointModelRevoluteUnaligned(a));
}

// A continuous joint is a revolute one here (one angle), as in eomgen.
inline pinocchio::JointModel urdf_joint_model(const eom::urdf::Joint& joint) {
  using eom::urdf::JointType;
  const bool prismatic = joint.type == JointType::prismatic;
  if (joint.type != JointType::revolute && joint.type != JointType::continuous && !prismatic)
    throw std::invalid_argument("joint " + joint.name + ": only revolute, continuous, prismatic "
                                "and fixed joints below the root are benchmarked");
  return axis_joint_model(joint.name, joint.axis, prismatic);
}

// Gravity: Pinocchio's default (0, 0, −9.81), eomgen's g = 9.81 along −z.
inline pinocchio::Model urdf_pinocchio_model(const eom::urdf::Robot& robot,
                                             const std::vector<std::string>& frames = {}) {
  std::map<std::string, std::size_t> link;
  for (std::size_t l = 0; l < robot.links.size(); ++l) link[robot.links[l].name] = l;
  std::vector<std::vector<std::size_t>> children(robot.links.size());
  for (std::size_t j = 0; j < robot.joints.size(); ++j)
    children[link.at(robot.joints[j].parent)].push_back(j);

  pinocchio::Model model;
  model.name = robot.name;
  std::vector<pinocchio::JointIndex> body(robot.links.size(), 0);  // 0: the universe
  std::vector<pinocchio::SE3> in_body(robot.links.size(), pinocchio::SE3::Identity());
  const std::size_t root = link.at(robot.root);
  if (robot.floating)
    body[root] = model.addJoint(0, pinocchio::JointModelFreeFlyer(), pinocchio::SE3::Identity(),
                                "root_joint");
  // Depth first, a link's joints in file order (as Pinocchio's URDF parser numbers them; eomgen
  // numbers them in file order, the same order only where the file lists parents first, as the
  // arms and the chain do, not Romeo): the stack holds joints, pushed reversed so that the first
  // is added first.
  std::vector<std::size_t> stack(children[root].rbegin(), children[root].rend());
  while (!stack.empty()) {
    const auto& joint = robot.joints[stack.back()];
    stack.pop_back();
    const std::size_t l = link.at(joint.parent), c = link.at(joint.child);
    const pinocchio::SE3 frame = in_body[l] * urdf_placement(joint.origin);
    if (joint.type == eom::urdf::JointType::fixed) {
      body[c] = body[l];
      in_body[c] = frame;
    } else {
      body[c] = model.addJoint(body[l], urdf_joint_model(joint), frame, joint.name);
      in_body[c] = pinocchio::SE3::Identity();
    }
    stack.insert(stack.end(), children[c].rbegin(), children[c].rend());
  }
  for (std::size_t l = 0; l < robot.links.size(); ++l) {
    const auto& k = robot.links[l];
    if (!k.has_inertial || body[l] == 0) continue;  // massless, or fixed to the world
    const auto& t = k.inertial.inertia;              // ixx iyy izz ixy ixz iyz
    Eigen::Matrix3d I;
    I << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
    model.appendBodyToJoint(body[l], pinocchio::Inertia(k.inertial.mass, Eigen::Vector3d::Zero(), I),
                            in_body[l] * urdf_placement(k.inertial.origin));
  }
  for (const std::string& name : frames) {
    const auto l = link.find(name);
    if (l == link.end()) throw std::invalid_argument(robot.file + ": no link " + name);
    model.addFrame(pinocchio::Frame(name, body[l->second], in_body[l->second],
                                    pinocchio::OP_FRAME));
  }
  return model;
}

inline pinocchio::SE3 tree_placement(const eom::Transform<double>& x) {
  return pinocchio::SE3(Eigen::Map<const Eigen::Matrix3d>(x.rotation.data()),  // column-major
                        Eigen::Map<const Eigen::Vector3d>(x.translation.data()));
}

// The same from a tree-form model (eom/multibody/tree.hpp), e.g. the header eomgen-mjcf writes:
// its links in their order, a free link as a JointModelFreeFlyer ("root_joint"), each moving link
// a joint named after its coordinate (its frame in the parent's: origin), fixed links merged into
// their parent body, each link's armature on its velocity; and Model's frames named in `frames`
// as OP_FRAMEs. Every joint must land on the coordinate eomgen gives it (checked); mimic and ball
// joints are refused.
template <class Model>
pinocchio::Model tree_pinocchio_model(const std::vector<std::string>& frames = {}) {
  std::array<eom::TreeLink<double>, Model::link_count> links;
  Model::template tree<double>(Model::parameter_values, links);
  pinocchio::Model model;
  std::vector<pinocchio::JointIndex> body(links.size(), 0);  // 0: the universe
  std::vector<pinocchio::SE3> in_body(links.size(), pinocchio::SE3::Identity());
  for (std::size_t l = 0; l < links.size(); ++l) {
    const auto& k = links[l];
    const std::size_t parent = k.parent < 0 ? 0 : static_cast<std::size_t>(k.parent);
    const pinocchio::JointIndex up = k.parent < 0 ? 0 : body[parent];
    const pinocchio::SE3 frame =
        (k.parent < 0 ? pinocchio::SE3::Identity() : in_body[parent]) * tree_placement(k.origin);
    const std::string name =
        k.coordinate < 0 ? "" : std::string(Model::coordinates[static_cast<std::size_t>(k.coordinate)]);
    if (k.ball || k.multiplier != 1.0 || k.offset != 0.0)
      throw std::invalid_argument("link " + std::to_string(l) + ": ball and mimic joints are "
                                  "not benchmarked");
    if (k.coordinate < 0) {
      body[l] = up;
      in_body[l] = frame;
      continue;
    }
    body[l] = k.free ? model.addJoint(0, pinocchio::JointModelFreeFlyer(), frame, "root_joint")
                     : model.addJoint(up, axis_joint_model(name, k.axis, k.prismatic), frame, name);
    if (model.idx_qs[body[l]] != k.coordinate)
      throw std::invalid_argument("joint " + name + ": coordinate " +
                                  std::to_string(model.idx_qs[body[l]]) + " in Pinocchio's order");
    if (k.armature != 0) {
      if (k.free) throw std::invalid_argument("armature on the free joint");
      model.armature[model.idx_vs[body[l]]] = k.armature;
    }
  }
  for (std::size_t l = 0; l < links.size(); ++l) {
    const auto& k = links[l];
    if (k.mass == 0 || body[l] == 0) continue;  // massless, or fixed to the world
    const Eigen::Matrix3d R = tree_placement(k.inertial).rotation();
    const auto& t = k.inertia;  // Ixx Iyy Izz Ixy Ixz Iyz about the mass centre, inertial axes
    Eigen::Matrix3d I;
    I << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
    model.appendBodyToJoint(body[l],
                            pinocchio::Inertia(k.mass, tree_placement(k.inertial).translation(),
                                               R * I * R.transpose()),
                            in_body[l]);
  }
  std::array<eom::LinkFrame<double>, Model::frame_names.size()> placed;
  Model::template link_frames<double>(Model::parameter_values, placed);
  for (const std::string& name : frames) {
    const auto f = std::find(Model::frame_names.begin(), Model::frame_names.end(), name);
    if (f == Model::frame_names.end()) throw std::invalid_argument("no frame " + name);
    const auto& x = placed[static_cast<std::size_t>(f - Model::frame_names.begin())];
    if (x.link < 0) throw std::invalid_argument("frame " + name + " is on the world");
    const auto l = static_cast<std::size_t>(x.link);
    model.addFrame(pinocchio::Frame(name, body[l], in_body[l] * tree_placement(x.offset),
                                    pinocchio::OP_FRAME));
  }
  return model;
}

}  // namespace eombench
