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

std::string model_header(const Robot& r, const HeaderOptions& options) {
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
  line("#pragma once");
  line("");
  line("#include <array>");
  line("#include <cmath>");
  line("#include <limits>");
  line("");
  line("#include <eom/model/model.hpp>");
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
