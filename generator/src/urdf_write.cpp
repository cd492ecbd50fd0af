// Writing an eom::urdf::Robot as a model header in the tree form (eom/multibody/tree.hpp): one TreeLink per
// link below the root (its parent, joint and inertial), the bodies written from that tree, the
// inertial values as named parameters with the file's values as defaults.
#include <fmt/format.h>

#include <cmath>
#include <algorithm>
#include <filesystem>
#include <map>
#include <set>

#include "emit_detail.hpp"  // wrap: long lists broken at 100 columns, as in generated code
#include "eom/contact/narrow_phase.hpp"  // eom::collides: the pairs the runtime models
#include "eom/multibody/scene.hpp"  // the scene's structs' defaults
#include "eom/multibody/tree.hpp"   // transforms and vector helpers, for its placements
#include "eomgen/urdf.hpp"

namespace eom::urdf {

std::string identifier(const std::string& name, const std::string& prefix) {
  std::string s;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    s += ok ? c : '_';
  }
  if (s.empty() || (s[0] >= '0' && s[0] <= '9')) s = prefix + s;
  return s;
}

namespace {

// A double literal that reads back to exactly v (v is finite: the reader checked).
std::string number(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}
std::string triple(const std::array<double, 3>& v) {
  return fmt::format("{{{}, {}, {}}}", number(v[0]), number(v[1]), number(v[2]));
}
bool is_zero(const std::array<double, 3>& v) { return v[0] == 0 && v[1] == 0 && v[2] == 0; }

// The scene's numbers (HeaderOptions::ground, collision_pairs): rigid placements at q = 0, by the
// runtime's own transforms (the model's kernels place links so, quarter turns exact), and MuJoCo's
// inverse weights (mj_setConst: body_invweight0, dof_invweight0) from the mass matrix there,
// computed here in double as MuJoCo computes them for the same tree.
using Vec3 = eom::Vec3<double>;
using Rot3 = eom::Rot3<double>;  // column-major
using Placement = eom::Transform<double>;
Placement placement(const Pose& p) { return eom::origin<double>(p.xyz, p.rpy); }
Vec3 unit(const Vec3& a) { return eom::detail::unit_axis(a).u; }
std::string list(const double* v, int n) {
  std::vector<std::string> items;
  for (int k = 0; k < n; ++k) items.push_back(number(v[k]));
  return fmt::format("{{{}}}", fmt::join(items, ", "));
}
std::string softness_field() {  // MuJoCo's default solref and solimp, stated
  const eom::Softness s;
  return fmt::format(".softness = {{.solref = {}, .solimp = {}}}", list(s.solref.data(), 2),
                     list(s.solimp.data(), 5));
}

// Distinct identifiers for a list of names; a collision after making identifiers is an error.
std::vector<std::string> identifiers(const Robot& r, const std::vector<std::string>& names,
                                     const std::string& what, const std::string& prefix) {
  std::map<std::string, std::string> seen;
  std::vector<std::string> ids;
  for (const std::string& n : names) {
    ids.push_back(identifier(n, prefix));
    if (const auto [it, fresh] = seen.emplace(ids.back(), n); !fresh)
      throw UrdfError(r.file + ": " + what + " '" + n + "' and '" + it->second +
                      "' both become the identifier '" + ids.back() + "'; rename one");
  }
  return ids;
}

}  // namespace

std::string model_header(const Robot& r, const HeaderOptions& options,
                         std::vector<std::string>* warnings) {
  const bool scene = options.ground || !options.collision_pairs.empty();
  if (scene && !r.collisions_read)
    throw UrdfError(r.file + ": a scene (ground or collision pairs) needs the robot read with its "
                    "<collision> elements (eom::urdf::ReadOptions::collisions)");
  const std::string class_name =
      options.class_name.empty() ? identifier(r.name, "robot_") : options.class_name;

  // The tree: each link's joint from its parent; children in file order.
  std::map<std::string, const Joint*> joint_to;
  std::map<std::string, std::vector<const Joint*>> children;
  for (const Joint& j : r.joints) {
    joint_to[j.child] = &j;
    children[j.parent].push_back(&j);
  }
  // Coordinates: a free root's seven (eom/model/free_joint.hpp), then the moving joints in file order,
  // but for mimic joints, which move with their leader's coordinate.
  const int free = r.floating ? 7 : 0;  // joint k moves q[free + k]
  std::map<std::string, int> coordinate_of;  // joint name → index among the joints
  std::vector<std::string> coordinate_names;
  for (const Joint& j : r.joints)
    if (j.type != JointType::fixed && !j.mimic) {
      coordinate_of[j.name] = static_cast<int>(coordinate_names.size());
      coordinate_names.push_back(j.name);
    }
  for (const Joint& j : r.joints)
    if (j.mimic) coordinate_of[j.name] = coordinate_of.at(j.mimic->leader);
  if (coordinate_names.empty() && !r.floating)
    throw UrdfError(r.file + ": robot '" + r.name + "' has no moving joint");

  // Links in depth-first order from the root; a link moves when a moving joint is above it.
  std::vector<std::string> order;
  std::map<std::string, bool> moves;
  std::vector<std::string> stack{r.root};
  moves[r.root] = r.floating;
  while (!stack.empty()) {
    const std::string link = stack.back();
    stack.pop_back();
    order.push_back(link);
    const auto& cs = children[link];
    for (auto it = cs.rbegin(); it != cs.rend(); ++it) {
      moves[(*it)->child] = moves[link] || (*it)->type != JointType::fixed;
      stack.push_back((*it)->child);
    }
  }
  // Bodies: links with mass (or inertia) that move, in file order.
  std::vector<const Link*> bodies;
  for (const Link& l : r.links) {
    const auto& J = l.inertial.inertia;
    const bool has_mass = l.has_inertial && (l.inertial.mass > 0 || J[0] > 0 || J[1] > 0 || J[2] > 0);
    if (has_mass && moves[l.name]) bodies.push_back(&l);
  }
  if (bodies.empty())
    throw UrdfError(r.file + ": robot '" + r.name + "': no link that moves has mass (every link " +
                    (r.floating ? "of the free robot" : "below a moving joint") +
                    " lacks <inertial>): its mass matrix would be singular");
  // Links in the tree: the bodies' links, every link a moving joint carries (so that every link
  // off the tree hangs from it or from the world by fixed joints only: a frame, below), and
  // everything above them.
  std::set<std::string> needed;
  std::vector<std::string> carried;
  for (const Link* l : bodies) carried.push_back(l->name);
  for (const Joint& j : r.joints)
    if (j.type != JointType::fixed) carried.push_back(j.child);
  for (const std::string& start : carried)
    for (std::string link = start; link != r.root && needed.insert(link).second;)
      link = joint_to[link]->parent;
  if (r.floating) needed.insert(r.root);

  // Names.
  std::vector<std::string> link_names;
  for (const Link& l : r.links) link_names.push_back(l.name);
  const auto link_ids = identifiers(r, link_names, "link", "link_");
  std::map<std::string, std::string> link_id;
  for (std::size_t i = 0; i < link_names.size(); ++i) link_id[link_names[i]] = link_ids[i];
  const auto joint_coordinates = identifiers(r, coordinate_names, "joint", "joint_");
  std::vector<std::string> coordinates;
  if (r.floating)
    for (const char* suffix : {"_x", "_y", "_z", "_qw", "_qx", "_qy", "_qz"})
      coordinates.push_back(link_id[r.root] + suffix);
  coordinates.insert(coordinates.end(), joint_coordinates.begin(), joint_coordinates.end());
  {  // the free joint's names must not collide with a joint's
    std::set<std::string> seen;
    for (const std::string& c : coordinates)
      if (!seen.insert(c).second)
        throw UrdfError(r.file + ": two coordinates are both named '" + c + "'; rename a joint");
  }

  std::vector<std::string> parameters{"g"};
  std::vector<double> values{9.81};
  std::map<const Link*, int> inertial_at;  // first parameter of a body's 10
  for (const Link* l : bodies) {
    inertial_at[l] = static_cast<int>(parameters.size());
    const std::string& id = link_id[l->name];
    for (const char* suffix : {"_mass", "_com_x", "_com_y", "_com_z", "_Ixx", "_Iyy", "_Izz",
                               "_Ixy", "_Ixz", "_Iyz"})
      parameters.push_back(id + suffix);
    values.push_back(l->inertial.mass);
    for (double x : l->inertial.origin.xyz) values.push_back(x);
    for (double x : l->inertial.inertia) values.push_back(x);
  }
  // Damping and friction of every moving joint (a mimic joint's act on its leader's coordinate).
  std::map<std::string, int> damping_at, friction_at;  // joint → parameter
  for (const Joint& j : r.joints)
    if (j.type != JointType::fixed && j.damping > 0) {
      damping_at[j.name] = static_cast<int>(parameters.size());
      parameters.push_back(identifier(j.name, "joint_") + "_damping");
      values.push_back(j.damping);
    }
  for (const Joint& j : r.joints)
    if (j.type != JointType::fixed && j.friction > 0) {
      friction_at[j.name] = static_cast<int>(parameters.size());
      parameters.push_back(identifier(j.name, "joint_") + "_friction");
      values.push_back(j.friction);
    }
  const int smoothing_at = static_cast<int>(parameters.size());
  if (!friction_at.empty()) {  // Coulomb friction f·tanh(q̇ / friction_smoothing)
    parameters.push_back("friction_smoothing");
    values.push_back(friction_smoothing);
  }
  {  // parameter names must be distinct too (a link called "g", or "a_mass" + "a" ...)
    std::set<std::string> seen;
    for (const std::string& p : parameters)
      if (!seen.insert(p).second)
        throw UrdfError(r.file + ": two parameters are both named '" + p + "'; rename a link or joint");
  }

  // `static constexpr <type> <name>{"a", "b", ...};` wrapped at 100 columns.
  auto array = [](const std::string& head, const std::vector<std::string>& items, bool quote) {
    std::vector<std::string> v;
    for (const auto& x : items) v.push_back(quote ? "\"" + x + "\"" : x);
    return gen::detail::wrap("  static constexpr " + head + "{", v, "};");
  };
  fmt::memory_buffer out;
  auto line = [&out](std::string_view text) { fmt::format_to(std::back_inserter(out), "{}\n", text); };

  line(fmt::format("// Robot '{}', written by eomgen-urdf from {}.", r.name,
                   std::filesystem::path(r.file).filename().string()));
  line("// A model in the tree form of the spatial body form: edit it like any model header (README");
  line("// \"URDF import\").");
  if (r.floating)
    line("//   coordinates  the free root link's position and quaternion (x, y, z, qw, qx, qy, qz;\n"
         "//                velocities vx, vy, vz in world axes, wx, wy, wz in its axes), then the\n"
         "//                moving joints in file order; inputs u: one torque or force per joint");
  else
    line("//   coordinates  the moving joints, in file order; inputs u: one torque or force per joint");
  line(r.floating ? "//   parameters   g (along -z of the world), each moving link's mass, mass centre (link"
                  : "//   parameters   g (along -z of the root link), each moving link's mass, mass centre (link");
  line("//                frame) and inertia about it (inertial axes), each damped joint's damping,");
  line("//                each joint's Coulomb friction and the friction_smoothing speed");
  line("//   tree         per link: parent, joint origin(xyz, rpy), coordinate and axis, inertial;");
  line("//                frame = parent * origin * revolute(axis, q) or prismatic(axis, q)");
  line("//   forces       Q = u - damping * qd - friction * tanh(qd / friction_smoothing), a mimic");
  line("//                joint's (times its multiplier, at multiplier * qd) added to its leader's");
  if (scene)
    line("//   scene        <collision> geoms, ground and pairs, limits and damping for\n"
         "//                eom::contact_step, MuJoCo's default contact parameters (add_eom_model's\n"
         "//                GROUND and COLLISION_PAIRS)");
  line("#pragma once");
  line("");
  line("#include <array>");
  line("#include <cmath>");
  line("#include <limits>");
  line("");
  line("#include <eom/model/model.hpp>");
  if (scene) line("#include <eom/multibody/scene.hpp>");
  line("#include <eom/multibody/tree.hpp>");
  line("");
  line(fmt::format("namespace {} {{", options.ns));
  line("");
  line(fmt::format("struct {} {{", class_name));
  line(array("std::array coordinates", coordinates, true));
  if (r.floating) line("  static constexpr bool floating_base = true;  // q[0..7): the free root (eom/model/free_joint.hpp)");
  if (r.inconsistent_inertia)
    line("  static constexpr bool inconsistent_inertia_accepted = true;  // eomgen-urdf --inertia warn");
  std::vector<std::string> inputs;
  for (const auto& c : joint_coordinates) inputs.push_back("u_" + c);
  if (!inputs.empty()) line(array("std::array inputs", inputs, true));
  line(array("std::array parameters", parameters, true));
  {  // <limit>: data for the user, not used by the dynamics
    std::vector<std::string> lower, upper, effort, velocity;
    auto bound = [](double x) {
      return std::isinf(x) ? (x > 0 ? "unlimited" : "-unlimited") : number(x);
    };
    for (int k = 0; k < free; ++k) lower.push_back("-unlimited"), upper.push_back("unlimited");
    for (int k = 0; k < (r.floating ? 6 : 0); ++k) effort.push_back("unlimited"), velocity.push_back("unlimited");
    for (const std::string& name : coordinate_names) {
      const Joint& j = *std::find_if(r.joints.begin(), r.joints.end(),
                                     [&](const Joint& x) { return x.name == name; });
      lower.push_back(bound(j.lower));
      upper.push_back(bound(j.upper));
      effort.push_back(bound(j.effort));
      velocity.push_back(bound(j.velocity));
    }
    line("  // <limit> of each coordinate's joint (q: nq entries, qd and u: nv), +-unlimited where the");
    line("  // file gives none (a continuous joint's position, the free joint): data, not dynamics.");
    line("  static constexpr double unlimited = std::numeric_limits<double>::infinity();");
    const std::size_t nq = lower.size(), nv = effort.size();
    line(array(fmt::format("std::array<double, {}> position_lower", nq), lower, false));
    line(array(fmt::format("std::array<double, {}> position_upper", nq), upper, false));
    line(array(fmt::format("std::array<double, {}> effort_limit", nv), effort, false));
    line(array(fmt::format("std::array<double, {}> velocity_limit", nv), velocity, false));
  }
  std::vector<std::string> value_text;
  for (double v : values) value_text.push_back(number(v));
  line(array(fmt::format("std::array<double, {}> parameter_values", values.size()), value_text, false));
  // The tree: the links needed, parents first (depth-first from the root); each a body.
  std::vector<std::string> tree_links;
  std::map<std::string, int> tree_index;
  for (const std::string& link : order)
    if ((link != r.root || r.floating) && needed.count(link)) {
      tree_index[link] = static_cast<int>(tree_links.size());
      tree_links.push_back(link);
    }
  line(fmt::format("  static constexpr int link_count = {};", tree_links.size()));
  line("  static constexpr int body_count = link_count;  // one body per link, massless ones of mass 0");
  line(r.floating ? "  // The links of the tree, in its order (the first flies free)."
                  : "  // The links of the tree, in its order (the root link is the world).");
  line(array("std::array tree_links", tree_links, true));
  line("");
  line("  // The kinematic tree (eom/multibody/tree.hpp): per link its parent, joint and inertial.");
  line("  template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l) {");
  line("    using eom::origin;");
  std::map<const Link*, bool> is_body;
  for (const Link* l : bodies) is_body[l] = true;
  for (std::size_t k = 0; k < tree_links.size(); ++k) {
    const Link& link = *std::find_if(r.links.begin(), r.links.end(),
                                     [&](const Link& l) { return l.name == tree_links[k]; });
    std::vector<std::string> fields;
    const bool root = tree_links[k] == r.root;  // the free root (tree link 0)
    const Joint* j = root ? nullptr : joint_to[tree_links[k]];
    if (root) {
      fields = {".parent = -1", ".coordinate = 0", ".free = true"};
    } else {
      fields.push_back(fmt::format(".parent = {}", j->parent == r.root && !r.floating ? -1 : tree_index[j->parent]));
      if (!is_zero(j->origin.xyz) || !is_zero(j->origin.rpy))
        fields.push_back(fmt::format(".origin = origin<S>({}, {})", triple(j->origin.xyz), triple(j->origin.rpy)));
    }
    if (j && j->type != JointType::fixed) {
      fields.push_back(fmt::format(".coordinate = {}", free + coordinate_of[j->name]));
      if (j->mimic && j->mimic->multiplier != 1)
        fields.push_back(fmt::format(".multiplier = {}", number(j->mimic->multiplier)));
      if (j->mimic && j->mimic->offset != 0)
        fields.push_back(fmt::format(".offset = {}", number(j->mimic->offset)));
      if (j->type == JointType::prismatic) fields.push_back(".prismatic = true");
      fields.push_back(fmt::format(".axis = {}", triple(j->axis)));
    }
    if (is_body[&link]) {
      const int a = inertial_at[&link];
      const std::string com = fmt::format("{{p[{}], p[{}], p[{}]}}", a + 1, a + 2, a + 3);
      fields.push_back(fmt::format(".mass = p[{}]", a));
      fields.push_back(fmt::format(".inertia = {{p[{}], p[{}], p[{}], p[{}], p[{}], p[{}]}}", a + 4,
                                   a + 5, a + 6, a + 7, a + 8, a + 9));
      fields.push_back(
          is_zero(link.inertial.origin.rpy)
              ? fmt::format(".inertial = eom::translation<S>({})", com)
              : fmt::format(".inertial = {{eom::constant_rpy<S>({}), {}}}",
                            triple(link.inertial.origin.rpy), com));
    }
    line(fmt::format("    // link '{}', joint '{}'{}{}", tree_links[k], root ? "(free)" : j->name,
                     j && j->mimic ? " (mimics '" + j->mimic->written_leader + "')" : "",
                     is_body[&link] ? "" : " (massless)"));
    line(gen::detail::wrap(fmt::format("    l[{}] = {{", k), fields, "};"));
  }
  line("  }");
  line("");
  // Frames: every link, at its own placement, on the tree link it hangs from through fixed joints
  // (itself when it is in the tree), or on the world.
  std::vector<std::string> frame_literals;
  for (const Link& l : r.links) frame_literals.push_back(gen::detail::string_literal(l.name));
  line("  // Every link is a frame (eom/multibody/frames.hpp), named as in the file: on its tree link, or fixed to");
  line("  // one (or to the world) through fixed joints at its own placement.");
  line(gen::detail::wrap("  static constexpr std::array frame_names{", frame_literals, "};"));
  line("  template <class S> static void link_frames(eom::In<S>, eom::Out<eom::LinkFrame<S>> f) {");
  line("    using eom::origin;");
  for (std::size_t k = 0; k < r.links.size(); ++k) {
    std::vector<std::string> offsets;  // the fixed joints' origins, outermost last
    std::string link = r.links[k].name;
    while (!tree_index.count(link) && link != r.root) {
      const Joint* j = joint_to[link];
      if (!is_zero(j->origin.xyz) || !is_zero(j->origin.rpy))
        offsets.insert(offsets.begin(), fmt::format("origin<S>({}, {})", triple(j->origin.xyz), triple(j->origin.rpy)));
      link = j->parent;
    }
    const int on = tree_index.count(link) ? tree_index[link] : -1;  // the fixed root: the world
    std::vector<std::string> fields{fmt::format(".link = {}", on)};
    if (!offsets.empty()) fields.push_back(fmt::format(".offset = {}", fmt::join(offsets, " * ")));
    line(fmt::format("    // {}{}", frame_literals[k], on < 0 ? ": on the world" : ""));
    line(gen::detail::wrap(fmt::format("    f[{}] = {{", k), fields, "};"));
  }
  line("  }");
  line("");
  if (scene) {
    // The scene as data (eom/multibody/scene.hpp) for eom::contact_step (docs/CONTRACT.md §1, "URDF:
    // the scene"): the links' <collision> geoms, the ground, the candidate pairs, the limits and
    // damping as MuJoCo would hold them for this tree, and MuJoCo's default parameters.
    const int nv = static_cast<int>(coordinate_names.size()) + (r.floating ? 6 : 0);
    const int vfree = r.floating ? 6 : 0;  // joint k's velocity: vfree + k
    // World placements at q = 0 (a mimic joint at its offset), every link.
    std::map<std::string, Placement> world;
    world[r.root] = Placement{};
    for (const std::string& link : order) {
      if (link == r.root) continue;
      const Joint* j = joint_to[link];
      Placement at = world[j->parent] * placement(j->origin);
      const double q0 = j->mimic ? j->mimic->offset : 0.0;
      if (j->type == JointType::prismatic)
        at = at * eom::prismatic<double>(j->axis, q0);
      else if (j->type != JointType::fixed)
        at = at * eom::revolute<double>(j->axis, q0);
      world[link] = at;
    }
    // The Jacobian (6 × nv, rows: linear velocity of world point p, then angular velocity, world
    // axes) of a point on a link, row-major.
    auto jacobian = [&](const std::string& on, const Vec3& p) {
      std::vector<double> J(6 * static_cast<std::size_t>(nv), 0.0);
      auto add = [&](int col, const Vec3& linear, const Vec3& angular, double m) {
        for (int i = 0; i < 3; ++i) {
          J[static_cast<std::size_t>(i * nv + col)] += m * linear[i];
          J[static_cast<std::size_t>((3 + i) * nv + col)] += m * angular[i];
        }
      };
      for (std::string link = on; link != r.root; link = joint_to[link]->parent) {
        const Joint* j = joint_to[link];
        if (j->type == JointType::fixed) continue;
        const int col = vfree + coordinate_of[j->name];
        const double m = j->mimic ? j->mimic->multiplier : 1.0;
        const Vec3 a = eom::rotate(world[link].rotation, unit(j->axis));
        if (j->type == JointType::prismatic)
          add(col, a, {0, 0, 0}, m);
        else
          add(col, eom::detail::cross(a, eom::detail::minus(p, world[link].translation)), a, m);
      }
      if (r.floating) {
        const Placement& b = world[r.root];
        for (int k = 0; k < 3; ++k) {
          Vec3 e{0, 0, 0};
          e[k] = 1;
          add(k, e, {0, 0, 0}, 1.0);
          const Vec3 w{b.rotation[3 * k], b.rotation[3 * k + 1], b.rotation[3 * k + 2]};  // body axis k
          add(3 + k, eom::detail::cross(w, eom::detail::minus(p, b.translation)), w, 1.0);
        }
      }
      return J;
    };
    // A tree link's mass centre in the world (its origin where massless), its inertia there.
    auto centre = [&](const Link& l) {
      const Placement& x = world[l.name];
      return is_body[&l] ? x.apply(l.inertial.origin.xyz) : x.translation;
    };
    // M at q = 0: Σ m Jpᵀ Jp + Jrᵀ I Jr over the bodies, at their mass centres.
    const std::size_t n = static_cast<std::size_t>(nv);
    std::vector<double> M(n * n, 0.0);
    for (const Link* l : bodies) {
      const std::vector<double> J = jacobian(l->name, centre(*l));
      const auto& I6 = l->inertial.inertia;  // ixx iyy izz ixy ixz iyz
      const Rot3 I{I6[0], I6[3], I6[4], I6[3], I6[1], I6[5], I6[4], I6[5], I6[2]};  // symmetric
      const Rot3 Rb = eom::multiply(world[l->name].rotation, eom::constant_rpy<double>(l->inertial.origin.rpy));
      const Rot3 Iw = eom::multiply(eom::multiply(Rb, I), eom::transpose(Rb));  // symmetric
      for (std::size_t a = 0; a < n; ++a)
        for (std::size_t b = 0; b < n; ++b) {
          double x = 0;
          for (std::size_t i = 0; i < 3; ++i) x += l->inertial.mass * J[i * n + a] * J[i * n + b];
          for (std::size_t i = 0; i < 3; ++i)
            for (std::size_t k = 0; k < 3; ++k)
              x += J[(3 + i) * n + a] * Iw[i + 3 * k] * J[(3 + k) * n + b];
          M[a * n + b] += x;
        }
    }
    // M⁻¹ by Cholesky (columns of the identity solved).
    std::vector<double> L = M;
    for (std::size_t j = 0; j < n; ++j) {
      double d = L[j * n + j];
      for (std::size_t k = 0; k < j; ++k) d -= L[j * n + k] * L[j * n + k];
      if (!(d > 0))
        throw UrdfError(r.file + ": robot '" + r.name + "': the mass matrix at q = 0 is singular, so "
                        "the contact scene's inverse weights (MuJoCo's invweight0) are undefined");
      L[j * n + j] = std::sqrt(d);
      for (std::size_t i = j + 1; i < n; ++i) {
        double x = L[i * n + j];
        for (std::size_t k = 0; k < j; ++k) x -= L[i * n + k] * L[j * n + k];
        L[i * n + j] = x / L[j * n + j];
      }
    }
    std::vector<double> Minv(n * n, 0.0);
    for (std::size_t c = 0; c < n; ++c) {
      std::vector<double> y(n, 0.0);
      y[c] = 1;
      for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t k = 0; k < i; ++k) y[i] -= L[i * n + k] * y[k];
        y[i] /= L[i * n + i];
      }
      for (std::size_t i = n; i-- > 0;) {
        for (std::size_t k = i + 1; k < n; ++k) y[i] -= L[k * n + i] * y[k];
        y[i] /= L[i * n + i];
      }
      for (std::size_t i = 0; i < n; ++i) Minv[i * n + c] = y[i];
    }
    // MuJoCo's body_invweight0 of a tree link: A = J M⁻¹ Jᵀ at its mass centre, the means of its
    // translational and rotational diagonals; the world's (−1): zero.
    auto inverse_weight = [&](int tree_link) -> std::array<double, 2> {
      if (tree_link < 0) return {0.0, 0.0};
      const Link& l = *std::find_if(r.links.begin(), r.links.end(),
                                    [&](const Link& x) { return x.name == tree_links[static_cast<std::size_t>(tree_link)]; });
      const std::vector<double> J = jacobian(l.name, centre(l));
      std::array<double, 6> diag{};
      for (std::size_t row = 0; row < 6; ++row)
        for (std::size_t a = 0; a < n; ++a)
          for (std::size_t b = 0; b < n; ++b) diag[row] += J[row * n + a] * Minv[a * n + b] * J[row * n + b];
      return {(diag[0] + diag[1] + diag[2]) / 3, (diag[3] + diag[4] + diag[5]) / 3};
    };

    // The geoms: the ground first (geom 0), then every link's <collision>s, links and collisions in
    // file order, each on the tree link it rides on (through fixed joints), or on the world.
    struct Placed {
      std::string link;  // the URDF link
      int tree_link;
      const Collision* c;  // nullptr: the ground
    };
    std::vector<Placed> placed;
    std::vector<std::vector<std::string>> geoms;
    std::vector<std::string> skipped;  // the <collision>s of other shapes
    const eom::Geom defaults;
    auto common = [&](std::vector<std::string>& f) {
      f.push_back(".friction = " + list(defaults.friction.data(), 3));
      f.push_back(softness_field());
    };
    if (options.ground) {
      placed.push_back({"", -1, nullptr});
      std::vector<std::string> f{".name = \"ground\"", ".shape = eom::Shape::plane", ".link = -1",
                                 ".size = {0.0, 0.0, 1.0}"};
      if (*options.ground != 0) f.push_back(fmt::format(".position = {{0.0, 0.0, {}}}", number(*options.ground)));
      common(f);
      geoms.push_back(f);
    }
    for (const Link& l : r.links) {
      if (l.collisions.empty()) continue;
      // the tree link it rides on and its placement there: the fixed joints' origins composed
      Placement offset;
      std::string on = l.name;
      while (!tree_index.count(on) && on != r.root) {
        const Joint* j = joint_to[on];
        offset = placement(j->origin) * offset;
        on = j->parent;
      }
      const int tree_link = tree_index.count(on) ? tree_index[on] : -1;
      for (const Collision& c : l.collisions) {
        if (c.kind == Collision::Kind::unsupported) {  // left out (the reader warned)
          skipped.push_back(fmt::format("{}:{} (link '{}', <{}>)",
                                        std::filesystem::path(r.file).filename().string(), c.line,
                                        l.name, c.shape));
          continue;
        }
        const Placement at = offset * placement(c.origin);
        std::vector<std::string> f;
        if (!c.name.empty()) f.push_back(".name = " + gen::detail::string_literal(c.name));
        Vec3 size{0, 0, 0};
        double rbound = 0;
        switch (c.kind) {
          case Collision::Kind::sphere:
            f.push_back(".shape = eom::Shape::sphere");
            size = {c.size[0], 0, 0};
            rbound = c.size[0];
            break;
          case Collision::Kind::capsule:
            f.push_back(".shape = eom::Shape::capsule");
            size = {c.size[0], c.size[1] / 2, 0};
            rbound = size[0] + size[1];
            break;
          case Collision::Kind::box:
            f.push_back(".shape = eom::Shape::box");
            size = {c.size[0] / 2, c.size[1] / 2, c.size[2] / 2};
            rbound = std::sqrt(size[0] * size[0] + size[1] * size[1] + size[2] * size[2]);
            break;
          case Collision::Kind::cylinder:
            f.push_back(".shape = eom::Shape::cylinder");
            size = {c.size[0], c.size[1] / 2, 0};
            rbound = std::sqrt(size[0] * size[0] + size[1] * size[1]);
            break;
          case Collision::Kind::unsupported:
            break;
        }
        f.push_back(fmt::format(".link = {}", tree_link));
        f.push_back(".size = " + list(size.data(), 3));
        if (at.rotation != eom::identity_rotation<double>()) f.push_back(".rotation = " + list(at.rotation.data(), 9));
        if (!is_zero(at.translation)) f.push_back(".position = " + list(at.translation.data(), 3));
        common(f);
        f.push_back(fmt::format(".rbound = {}", number(rbound)));
        placed.push_back({l.name, tree_link, &c});
        geoms.push_back(f);
      }
    }
    // The candidate pairs: the ground against every geom on a moving link, then each
    // COLLISION_PAIRS entry's geoms (A's against B's), in the order given; each pair ordered by
    // shape as MuJoCo orders it, with MuJoCo's default contact parameters; a pair of shapes
    // eom::collide does not model (a cylinder against anything but the ground) left out with a
    // warning.
    std::vector<std::vector<std::string>> pairs;
    std::vector<std::string> left_out;  // those pairs, for the header's comment
    const int shape_rank[] = {6, 2, 3, -1, 5};  // Collision::Kind → eom::Shape's number
    const char* shape_names[] = {"box", "sphere", "capsule", "", "cylinder"};
    auto rank = [&](std::size_t g) { return placed[g].c ? shape_rank[static_cast<int>(placed[g].c->kind)] : 0; };
    auto add_pair = [&](std::size_t g1, std::size_t g2) {
      if (rank(g1) > rank(g2)) std::swap(g1, g2);
      if (!eom::collides(static_cast<eom::Shape>(rank(g1)), static_cast<eom::Shape>(rank(g2)))) {
        auto what = [&](std::size_t g) {
          return fmt::format("link '{}''s <{}> (line {})", placed[g].link,
                             shape_names[static_cast<int>(placed[g].c->kind)], placed[g].c->line);
        };
        const std::size_t c = rank(g2) == 5 ? g2 : g1;  // the cylinder
        left_out.push_back(fmt::format("{}:{} (link '{}', <cylinder>) against {}",
                                       std::filesystem::path(r.file).filename().string(),
                                       placed[c].c->line, placed[c].link, what(c == g1 ? g2 : g1)));
        if (warnings)
          warnings->push_back(fmt::format(
              "{}:{}: link '{}': its <cylinder> against {}: pair left out: a cylinder collides "
              "with the ground only (MuJoCo finds its other contacts by libccd's iterative MPR, "
              "which eomgen does not reproduce; a capsule or a box may stand in for it)",
              r.file, placed[c].c->line, placed[c].link, what(c == g1 ? g2 : g1)));
        return;
      }
      const auto w1 = inverse_weight(placed[g1].tree_link), w2 = inverse_weight(placed[g2].tree_link);
      const std::array<double, 2> w{w1[0] + w2[0], w1[1] + w2[1]};
      const eom::CollisionPair pd;
      pairs.push_back({fmt::format(".geom1 = {}", g1), fmt::format(".geom2 = {}", g2),
                       fmt::format(".condim = {}", pd.condim), ".friction = " + list(pd.friction.data(), 5),
                       fmt::format(".margin = {}", number(pd.margin)), fmt::format(".gap = {}", number(pd.gap)),
                       softness_field(), ".inverse_weight = " + list(w.data(), 2)});
    };
    if (options.ground)
      for (std::size_t g = 1; g < placed.size(); ++g)
        if (placed[g].tree_link >= 0) add_pair(0, g);
    std::map<std::string, int> link_line;
    for (const Link& l : r.links) link_line[l.name] = l.line;
    for (const std::string& entry : options.collision_pairs) {
      const std::size_t colon = entry.find(':');
      const std::string what = r.file + ": COLLISION_PAIRS '" + entry + "': ";
      if (colon == std::string::npos || entry.find(':', colon + 1) != std::string::npos)
        throw UrdfError(what + "expected <linkA>:<linkB>");
      const std::string a = entry.substr(0, colon), b = entry.substr(colon + 1);
      for (const std::string& x : {a, b})
        if (!link_line.count(x)) {
          std::string names;
          for (const Link& l : r.links) names += (names.empty() ? "'" : ", '") + l.name + "'";
          throw UrdfError(what + "no link '" + x + "' (the links: " + names + ")");
        }
      if (a == b) throw UrdfError(what + "a link against itself");
      std::vector<std::size_t> ga, gb;
      for (std::size_t g = 0; g < placed.size(); ++g) {
        if (placed[g].c && placed[g].link == a) ga.push_back(g);
        if (placed[g].c && placed[g].link == b) gb.push_back(g);
      }
      for (const auto& [x, gx] : {std::pair{a, ga}, std::pair{b, gb}})
        if (gx.empty()) {
          const Link& l = *std::find_if(r.links.begin(), r.links.end(),
                                        [&, &x = x](const Link& y) { return y.name == x; });
          throw UrdfError(r.file + ":" + std::to_string(link_line[x]) + ": link '" + x +
                          "': COLLISION_PAIRS '" + entry + "' names it, but it has no <collision>" +
                          (l.collisions.empty() ? std::string()
                                                : " of a shape that collides (box, sphere, capsule, "
                                                  "cylinder; its others are skipped)"));
        }
      if (placed[ga[0]].tree_link == placed[gb[0]].tree_link)
        throw UrdfError(what + "links '" + a + "' and '" + b + "' never move apart (" +
                        (placed[ga[0]].tree_link < 0 ? std::string("both fixed to the world")
                                                     : "both on the tree link '" +
                                                           tree_links[static_cast<std::size_t>(placed[ga[0]].tree_link)] + "'") +
                        "): they can never touch otherwise than they do at rest");
      for (std::size_t g1 : ga)
        for (std::size_t g2 : gb) add_pair(g1, g2);
    }

    auto entries = [&](const std::string& type, const std::string& name,
                       const std::vector<std::vector<std::string>>& items) {
      fmt::format_to(std::back_inserter(out), "{}", gen::detail::scene_table(type, name, items));
    };
    line("  // The scene as data (eom/multibody/scene.hpp), for eom::contact_step (docs/CONTRACT.md §1,");
    line("  // \"URDF: the scene\"): the <collision> geoms (and the ground), the candidate pairs, the");
    line("  // joints' <limit>s and damping as MuJoCo's, MuJoCo's default contact parameters and");
    line("  // options; the dynamics above do not use them. Friction stays in generalized_forces.");
    if (!skipped.empty()) {
      line("  // Left out, shapes that do not collide here (the build warned):");
      for (const std::string& x : skipped) line("  //   " + x);
    }
    if (!left_out.empty()) {
      line("  // Left out, COLLISION_PAIRS pairs that do not collide here (the build warned):");
      for (const std::string& x : left_out) line("  //   " + x);
    }
    entries("eom::Geom", "geoms", geoms);
    entries("eom::CollisionPair", "collision_pairs", pairs);
    std::vector<std::vector<std::string>> limits;
    for (const std::string& name : coordinate_names) {
      const Joint& j = *std::find_if(r.joints.begin(), r.joints.end(),
                                     [&](const Joint& x) { return x.name == name; });
      if (std::isinf(j.lower) || std::isinf(j.upper)) continue;  // MuJoCo's range needs both
      const int k = coordinate_of[name];
      const std::size_t v = static_cast<std::size_t>(vfree + k);
      limits.push_back({".joint = " + gen::detail::string_literal(name),
                        fmt::format(".coordinate = {}", free + k), fmt::format(".velocity = {}", v),
                        fmt::format(".lower = {}", number(j.lower)),
                        fmt::format(".upper = {}", number(j.upper)), ".margin = 0.0", softness_field(),
                        fmt::format(".inverse_weight = {}", number(Minv[v * n + v]))});
    }
    entries("eom::JointLimit", "joint_limits", limits);
    entries("eom::FrictionLoss", "friction_losses", {});
    entries("eom::EqualitySoftness", "equality_softness", {});
    entries("eom::FixedTendon<1>", "tendons", {});
    {  // per velocity: the joints' damping on it (a mimic's times its multiplier squared)
      std::vector<double> damping(n, 0.0);
      for (const Joint& j : r.joints)
        if (j.type != JointType::fixed && j.damping > 0) {
          const double m = j.mimic ? j.mimic->multiplier : 1.0;
          damping[static_cast<std::size_t>(vfree + coordinate_of[j.name])] += m * m * j.damping;
        }
      std::vector<std::string> text;
      for (double d : damping) text.push_back(number(d));
      line("  // Each velocity's damping, taken implicitly by the Euler step (as MuJoCo's <joint damping>);");
      line("  // generalized_forces holds the same damping (MuJoCo's passive force).");
      line(gen::detail::wrap(fmt::format("  static constexpr std::array<double, {}> damping{{", nv), text, "};"));
    }
    {  // as MuJoCo's qpos0 of the robot (its root at the origin, unturned, if free)
      std::vector<std::string> q(static_cast<std::size_t>(free) + coordinate_names.size(), number(0.0));
      if (r.floating) q[3] = number(1.0);
      line("  // The configuration the file places the links in (MuJoCo's qpos0): every joint at 0, the free");
      line("  // root (if any) at the origin, unturned.");
      line(gen::detail::wrap(fmt::format("  static constexpr std::array<double, {}> qpos0{{", q.size()), q, "};"));
    }
    line("  // MuJoCo's default <option>s: Euler, pyramidal cones, the Newton solver.");
    line(gen::detail::solver_options_text(eom::SolverOptions{}, number));
    entries(fmt::format("eom::Keyframe<{}, {}, {}>", free + coordinate_names.size(), nv,
                        coordinate_names.size()),
            "keyframes", {});
    line("");
  }
  line("  template <class S>");
  line("  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {");
  line("    std::array<eom::TreeLink<S>, link_count> l;");
  line("    tree<S>(p, l);");
  line("    eom::tree_bodies<S>(l, q, b);");
  line("  }");
  line("");
  line("  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {");
  line("    std::array<eom::SpatialBody<S>, body_count> b;");
  line("    bodies<S>(q, p, b);");
  line("    return eom::gravity_potential<S>(b, p[0]);");
  line("  }");
  line("");
  line("  template <class S>");
  const bool dissipative = !damping_at.empty() || !friction_at.empty();
  line(fmt::format("  static void generalized_forces(const S&, eom::In<S>, eom::In<S>{}, eom::In<S>{}, "
                   "eom::In<S>{}, eom::Out<S> Q) {{",
                   dissipative ? " qd" : "", inputs.empty() ? "" : " u", dissipative ? " p" : ""));
  if (!friction_at.empty()) line("    using std::tanh;");
  if (r.floating) line("    for (int i = 0; i < 6; ++i) Q[i] = S(0);  // the free joint: no actuator");
  const std::size_t at = r.floating ? 6 : 0;  // joint k's velocity
  for (std::size_t k = 0; k < coordinate_names.size(); ++k) {
    std::string terms = fmt::format("u[{}]", k);
    for (const Joint& j : r.joints) {  // the joints coordinate k moves: its own, its mimics
      if (j.type == JointType::fixed || coordinate_of[j.name] != static_cast<int>(k)) continue;
      const double m = j.mimic ? j.mimic->multiplier : 1.0;
      const std::string rate = m == 1 ? fmt::format("qd[{}]", at + k)
                                      : fmt::format("{} * qd[{}]", number(m), at + k);
      const std::string times =  // the force on q_k: m τ_joint
          m == 1 ? std::string() : m < 0 ? fmt::format("({}) * ", number(m)) : fmt::format("{} * ", number(m));
      if (const auto d = damping_at.find(j.name); d != damping_at.end())
        terms += fmt::format(" - {}p[{}] * {}", times, d->second, m == 1 ? rate : "(" + rate + ")");
      if (const auto f = friction_at.find(j.name); f != friction_at.end())
        terms += fmt::format(" - {}p[{}] * tanh({} / p[{}])", times, f->second,
                             m == 1 ? rate : "(" + rate + ")", smoothing_at);
    }
    line(fmt::format("    Q[{}] = {};", at + k, terms));
  }
  line("  }");
  line("};");
  line("");
  line(fmt::format("}}  // namespace {}", options.ns));
  return fmt::to_string(out);
}

}  // namespace eom::urdf
