// Reading a URDF file into eom::urdf::Robot (tinyxml2), and every check the file must pass before
// it becomes a model: each problem is one UrdfError naming the file, the line, the joint or link,
// and what is wrong.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string_view>
#include <vector>

#include <tinyxml2.h>

#include <eom/multibody/body_check.hpp>

#include "eomgen/urdf.hpp"

namespace eom::urdf {

namespace {

// The symmetric J = (Jxx, Jyy, Jzz, Jxy, Jxz, Jyz) made physically consistent in place: its
// eigen-decomposition (cyclic Jacobi rotations), the principal moments clamped to ≥ 0, then, if
// the largest exceeds the sum of the other two, projected onto λ₃ = λ₁ + λ₂ (the nearest point of
// that plane: each small moment up by e/3, the largest down by e/3, e the excess); returns
// ‖J' − J‖ / ‖J‖ (Frobenius).
double nearest_inertia(std::array<double, 6>& J) {
  double a[3][3] = {{J[0], J[3], J[4]}, {J[3], J[1], J[5]}, {J[4], J[5], J[2]}};
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    if (off == 0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 3; ++k) {  // A ← A G (columns p, q)
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // A ← Gᵀ A (rows p, q)
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // V ← V G
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  std::array<double, 3> lambda{std::max(a[0][0], 0.0), std::max(a[1][1], 0.0), std::max(a[2][2], 0.0)};
  const int big = static_cast<int>(std::max_element(lambda.begin(), lambda.end()) - lambda.begin());
  const double excess = lambda[big] - (lambda[0] + lambda[1] + lambda[2] - lambda[big]);
  if (excess > 0)
    for (int k = 0; k < 3; ++k) lambda[k] += (k == big ? -excess : excess) / 3;
  auto entry = [&](int i, int j) {
    return lambda[0] * v[i][0] * v[j][0] + lambda[1] * v[i][1] * v[j][1] + lambda[2] * v[i][2] * v[j][2];
  };
  const std::array<double, 6> out{entry(0, 0), entry(1, 1), entry(2, 2), entry(0, 1), entry(0, 2), entry(1, 2)};
  double diff = 0, norm = 0;
  for (int k = 0; k < 6; ++k) {
    const double w = k < 3 ? 1 : 2;  // off-diagonal entries count twice
    diff += w * (out[k] - J[k]) * (out[k] - J[k]);
    norm += w * J[k] * J[k];
  }
  J = out;
  return norm > 0 ? std::sqrt(diff / norm) : 0;
}

bool is_identity(const Pose& p) {
  return p.xyz == std::array<double, 3>{0, 0, 0} && p.rpy == std::array<double, 3>{0, 0, 0};
}

using tinyxml2::XMLElement;

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const XMLElement* at, const std::string& what) const {
    std::string where = file_;
    if (at) where += ":" + std::to_string(at->GetLineNum());
    throw UrdfError(where + ": " + what);
  }

  std::string attribute(const XMLElement* e, const char* name, const std::string& owner) const {
    const char* v = e->Attribute(name);
    if (!v) fail(e, owner + ": <" + std::string(e->Name()) + "> has no " + name + " attribute");
    return v;
  }

  // `count` finite numbers separated by white space, e.g. xyz="0 0 0.333".
  template <std::size_t N>
  std::array<double, N> numbers(const XMLElement* e, const char* name, const std::string& owner,
                                const std::array<double, N>& fallback) const {
    const char* text = e->Attribute(name);
    if (!text) return fallback;
    std::array<double, N> v{};
    std::string_view s(text);
    std::size_t n = 0;
    auto bad = [&](const std::string& why) {
      fail(e, owner + ": " + std::string(e->Name()) + " " + name + "=\"" + std::string(text) +
                  "\": " + why);
    };
    while (true) {
      while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
      if (s.empty()) break;
      if (s.front() == '+') s.remove_prefix(1);
      double x = 0;
      const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), x);
      if (error == std::errc::result_out_of_range) bad("out of the range of double");
      if (error != std::errc() ||
          (end != s.data() + s.size() && !std::isspace(static_cast<unsigned char>(*end))))
        bad("not a number");
      if (!std::isfinite(x)) bad("not finite");
      if (n == N) bad("expected " + std::to_string(N) + " number" + (N > 1 ? "s" : ""));
      v[n++] = x;
      s.remove_prefix(static_cast<std::size_t>(end - s.data()));
    }
    if (n != N) bad("expected " + std::to_string(N) + " number" + (N > 1 ? "s" : ""));
    return v;
  }
  double number(const XMLElement* e, const char* name, const std::string& owner) const {
    if (!e->Attribute(name))
      fail(e, owner + ": <" + std::string(e->Name()) + "> has no " + name + " attribute");
    return numbers<1>(e, name, owner, {0})[0];
  }
  // An optional child element, at most once.
  const XMLElement* child(const XMLElement* e, const char* name, const std::string& owner) const {
    const XMLElement* c = e->FirstChildElement(name);
    if (c && c->NextSiblingElement(name))
      fail(c->NextSiblingElement(name), owner + ": more than one <" + std::string(name) + ">");
    return c;
  }
  Pose pose(const XMLElement* parent, const std::string& owner) const {
    Pose p;
    if (const XMLElement* o = child(parent, "origin", owner)) {
      p.xyz = numbers<3>(o, "xyz", owner, p.xyz);
      p.rpy = numbers<3>(o, "rpy", owner, p.rpy);
    }
    return p;
  }

  // A <collision>: its origin and the one shape inside its <geometry>, sizes positive.
  Collision collision(const XMLElement* e, const std::string& owner) const {
    Collision c;
    c.line = e->GetLineNum();
    if (const char* n = e->Attribute("name")) c.name = n;
    c.origin = pose(e, owner);
    const XMLElement* geometry = child(e, "geometry", owner);
    if (!geometry) fail(e, owner + ": <collision> has no <geometry>");
    const XMLElement* shape = geometry->FirstChildElement();
    if (!shape) fail(geometry, owner + ": <geometry> is empty");
    if (shape->NextSiblingElement())
      fail(shape->NextSiblingElement(), owner + ": <geometry> holds more than one shape");
    const std::string kind = shape->Name();
    auto positive = [&](double x, const char* what) {
      if (!(x > 0)) fail(shape, owner + ": <" + kind + "> " + what + " must be > 0");
      return x;
    };
    if (kind == "box") {
      c.kind = Collision::Kind::box;
      if (!shape->Attribute("size")) fail(shape, owner + ": <box> has no size attribute");
      c.size = numbers<3>(shape, "size", owner, c.size);
      for (double x : c.size) positive(x, "size");
    } else if (kind == "sphere") {
      c.kind = Collision::Kind::sphere;
      c.size[0] = positive(number(shape, "radius", owner), "radius");
    } else if (kind == "capsule" || kind == "cylinder") {
      c.kind = kind == "capsule" ? Collision::Kind::capsule : Collision::Kind::cylinder;
      c.size[0] = positive(number(shape, "radius", owner), "radius");
      c.size[1] = positive(number(shape, "length", owner), "length");
    } else {  // skipped with a warning (Robot::warnings), named in the header
      c.kind = Collision::Kind::unsupported;
      c.shape = kind;
    }
    return c;
  }

  Link link(const XMLElement* e, bool collisions) const {
    Link l;
    l.name = attribute(e, "name", "a <link>");
    l.line = e->GetLineNum();
    const std::string owner = "link '" + l.name + "'";
    if (collisions)
      for (const XMLElement* c = e->FirstChildElement("collision"); c;
           c = c->NextSiblingElement("collision"))
        l.collisions.push_back(collision(c, owner));
    const XMLElement* inertial = child(e, "inertial", owner);
    if (!inertial) return l;
    l.has_inertial = true;
    l.inertial.origin = pose(inertial, owner);
    const XMLElement* mass = child(inertial, "mass", owner);
    if (!mass) fail(inertial, owner + ": <inertial> has no <mass>");
    l.inertial.mass = number(mass, "value", owner);
    if (l.inertial.mass < 0) fail(mass, owner + ": negative mass " + std::to_string(l.inertial.mass));
    const XMLElement* inertia = child(inertial, "inertia", owner);
    if (!inertia) fail(inertial, owner + ": <inertial> has no <inertia>");
    const char* names[6] = {"ixx", "iyy", "izz", "ixy", "ixz", "iyz"};
    for (int i = 0; i < 6; ++i) l.inertial.inertia[i] = number(inertia, names[i], owner);
    return l;
  }

  // A link's inertia problem ("" when consistent): checked once the tree says whether it moves.
  static std::string inertia_problem(const Link& l) {
    SpatialBody<double> body;
    body.mass = l.inertial.mass;
    body.inertia = l.inertial.inertia;
    body.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    return body_problem(body);
  }

  Joint joint(const XMLElement* e) const {
    Joint j;
    j.name = attribute(e, "name", "a <joint>");
    const std::string owner = "joint '" + j.name + "'";
    const std::string type = attribute(e, "type", owner);
    if (type == "revolute") j.type = JointType::revolute;
    else if (type == "continuous") j.type = JointType::continuous;
    else if (type == "prismatic") j.type = JointType::prismatic;
    else if (type == "fixed") j.type = JointType::fixed;
    else if (type == "floating") j.type = JointType::floating;
    else if (type == "planar")
      fail(e, owner + ": planar joints are not supported yet (planned: a 3-dof planar joint with "
                      "its own coordinates); model the root motion by hand, or fix the joint");
    else
      fail(e, owner + ": unknown joint type '" + type +
                  "' (expected revolute, continuous, prismatic, fixed or floating)");
    if (const XMLElement* mimic = child(e, "mimic", owner)) {
      Joint::Mimic m;
      m.leader = m.written_leader = attribute(mimic, "joint", owner);
      if (mimic->Attribute("multiplier")) m.multiplier = number(mimic, "multiplier", owner);
      if (mimic->Attribute("offset")) m.offset = number(mimic, "offset", owner);
      if (m.leader == j.name) fail(mimic, owner + ": <mimic joint> names the joint itself");
      j.mimic = m;
    }
    const XMLElement* parent = child(e, "parent", owner);
    const XMLElement* child_link = child(e, "child", owner);
    if (!parent) fail(e, owner + ": no <parent link=...>");
    if (!child_link) fail(e, owner + ": no <child link=...>");
    j.parent = attribute(parent, "link", owner);
    j.child = attribute(child_link, "link", owner);
    j.origin = pose(e, owner);
    if (const XMLElement* axis = child(e, "axis", owner)) {
      j.axis = numbers<3>(axis, "xyz", owner, j.axis);
      if (j.type != JointType::fixed && j.axis[0] == 0 && j.axis[1] == 0 && j.axis[2] == 0)
        fail(axis, owner + ": zero joint axis");
    }
    if (const XMLElement* dynamics = child(e, "dynamics", owner)) {
      if (dynamics->Attribute("damping")) j.damping = number(dynamics, "damping", owner);
      if (j.damping < 0) fail(dynamics, owner + ": negative damping " + std::to_string(j.damping));
      if (dynamics->Attribute("friction")) j.friction = number(dynamics, "friction", owner);
      if (j.friction < 0) fail(dynamics, owner + ": negative friction " + std::to_string(j.friction));
    }
    if (const XMLElement* limit = child(e, "limit", owner)) {
      const bool position = j.type == JointType::revolute || j.type == JointType::prismatic;
      if (position && limit->Attribute("lower")) j.lower = number(limit, "lower", owner);
      if (position && limit->Attribute("upper")) j.upper = number(limit, "upper", owner);
      if (limit->Attribute("effort")) j.effort = number(limit, "effort", owner);
      if (limit->Attribute("velocity")) j.velocity = number(limit, "velocity", owner);
      if (j.lower > j.upper)
        fail(limit, owner + ": <limit> lower " + std::to_string(j.lower) + " > upper " +
                        std::to_string(j.upper) + "; swap them");
      if (j.effort < 0 || j.velocity < 0)
        fail(limit, owner + ": <limit> effort and velocity must be >= 0 (they bound |tau| and |qd|)");
    }
    return j;
  }

  Robot robot(const std::string& text, const ReadOptions& options) const {
    const bool free_root = options.free_root;
    tinyxml2::XMLDocument doc;
    if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS)
      throw UrdfError(file_ + ":" + std::to_string(doc.ErrorLineNum()) + ": malformed XML (" +
                      doc.ErrorName() + ")");
    const XMLElement* root = doc.RootElement();
    if (root) refuse_xacro(root);
    if (!root || std::string_view(root->Name()) != "robot")
      fail(root, "the top element must be <robot>");
    Robot r;
    r.file = file_;
    r.collisions_read = options.collisions;
    r.name = attribute(root, "name", "<robot>");
    std::map<std::string, const XMLElement*> link_at, joint_at;
    for (const XMLElement* e = root->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
      r.links.push_back(link(e, options.collisions));
      if (!link_at.emplace(r.links.back().name, e).second)
        fail(e, "link '" + r.links.back().name + "' is defined twice");
    }
    for (const Link& l : r.links)
      for (const Collision& c : l.collisions)
        if (c.kind == Collision::Kind::unsupported)
          r.warnings.push_back(file_ + ":" + std::to_string(c.line) + ": link '" + l.name +
                               "': <collision> shape <" + c.shape + "> skipped: only box, sphere, " +
                               "capsule and cylinder collide (" +
                               (c.shape == "mesh" ? std::string("a box, sphere or capsule around it may stand in for it")
                                                  : std::string("not a URDF shape")) +
                               ")");
    if (r.links.empty())
      fail(root, "robot '" + r.name + "' has no <link>" +
                     (declares_xacro(root) ? std::string(" (it declares the xacro namespace: if it is a "
                                                         "xacro file, ") + expand_xacro + ")"
                                           : std::string()));
    std::map<std::string, std::string> parent_joint;  // child link → joint
    for (const XMLElement* e = root->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
      r.joints.push_back(joint(e));
      const Joint& j = r.joints.back();
      if (!joint_at.emplace(j.name, e).second) fail(e, "joint '" + j.name + "' is defined twice");
      for (const std::string* l : {&j.parent, &j.child})
        if (!link_at.count(*l)) fail(e, "joint '" + j.name + "': unknown link '" + *l + "'");
      if (j.parent == j.child) fail(e, "joint '" + j.name + "': link '" + j.child + "' is its own parent");
      if (const auto [it, fresh] = parent_joint.emplace(j.child, j.name); !fresh)
        fail(e, "joint '" + j.name + "': link '" + j.child + "' is already the child of joint '" +
                    it->second + "' (a link has one parent: a kinematic loop?)");
    }
    std::vector<std::string> roots;
    for (const Link& l : r.links)
      if (!parent_joint.count(l.name)) roots.push_back(l.name);
    if (roots.empty())
      fail(root, "no root link: every link is some joint's child (a kinematic loop)");
    if (roots.size() > 1) {
      std::string list;
      for (const auto& n : roots) list += (list.empty() ? "'" : ", '") + n + "'";
      fail(root, "more than one root link (" + list + "): the links must form one tree");
    }
    r.root = roots.front();
    // Every link must hang from the root; the rest form a loop among themselves.
    std::set<std::string> reached{r.root};
    for (bool grew = true; grew;) {
      grew = false;
      for (const Joint& j : r.joints)
        if (reached.count(j.parent) && reached.insert(j.child).second) grew = true;
    }
    for (const Joint& j : r.joints)
      if (!reached.count(j.child))
        fail(joint_at[j.name], "joint '" + j.name + "': link '" + j.child +
                                   "' is not connected to the root link '" + r.root +
                                   "' (a kinematic loop)");
    // A floating joint: the massless root and the joint go, its child flies free.
    const Joint* floating = nullptr;
    for (const Joint& j : r.joints) {
      if (j.type != JointType::floating) continue;
      const XMLElement* at = joint_at[j.name];
      const std::string owner = "joint '" + j.name + "'";
      if (floating)
        fail(at, owner + ": a second floating joint (the first is '" + floating->name +
                     "'): a model has one free joint, at the root");
      floating = &j;
      if (j.parent != r.root)
        fail(at, owner + ": a floating joint must hang from the root link '" + r.root +
                     "', not from '" + j.parent + "' (one free joint, at the root)");
      const Link& world = *std::find_if(r.links.begin(), r.links.end(),
                                        [&](const Link& l) { return l.name == r.root; });
      if (world.has_inertial)
        fail(link_at[r.root], "link '" + r.root + "': the parent of floating joint '" + j.name +
                                  "' has <inertial>: it stands for the world and must be massless");
      for (const Joint& other : r.joints)
        if (&other != &j && other.parent == r.root)
          fail(joint_at[other.name], "joint '" + other.name + "': attached to '" + r.root +
                                         "', the world of floating joint '" + j.name +
                                         "': a free robot has nothing fixed to the world");
      if (!is_identity(j.origin))
        fail(at, owner + ": a floating joint's <origin> must be the identity: q's first seven "
                         "entries place link '" + j.child + "' in the world (give the initial pose there)");
    }
    const bool has_floating_joint = floating != nullptr;
    if (floating) {
      if (free_root)
        fail(joint_at[floating->name], "joint '" + floating->name + "': the file has a floating "
                                       "joint already; leave out FLOATING_BASE (--floating-base)");
      const std::string world = r.root, child_link = floating->child;
      r.joints.erase(r.joints.begin() + (floating - r.joints.data()));
      r.links.erase(std::find_if(r.links.begin(), r.links.end(),
                                 [&](const Link& l) { return l.name == world; }));
      r.root = child_link;
    }
    r.floating = has_floating_joint || free_root;
    if (!r.floating && std::none_of(r.joints.begin(), r.joints.end(),
                                    [](const Joint& j) { return j.type != JointType::fixed; }))
      fail(root, "robot '" + r.name + "' has no moving joint" +
                     (r.joints.empty() ? "" : " (every joint is fixed)") +
                     ", and its root link '" + r.root + "' is fixed to the world: nothing moves. "
                     "A robot that flies free (a drone, a spacecraft, a floating base) needs "
                     "FLOATING_BASE: add_eom_model(... FLOATING_BASE), "
                     "eomgen.build(..., floating_base=True), eomgen-urdf --floating-base");
    resolve_mimics(r, joint_at);
    check_inertias(r, link_at, options.inertia);
    return r;
  }

  // Each <mimic> resolved to a leader with a coordinate of its own; a mimic on a fixed joint is
  // dropped with a warning (the joint does not move).
  void resolve_mimics(Robot& r, std::map<std::string, const XMLElement*>& joint_at) const {
    std::map<std::string, Joint*> by_name;
    for (Joint& j : r.joints) by_name[j.name] = &j;
    auto line = [&](const std::string& joint) {
      return file_ + ":" + std::to_string(joint_at[joint]->GetLineNum()) + ": ";
    };
    for (Joint& j : r.joints) {
      if (!j.mimic) continue;
      const XMLElement* at = joint_at[j.name]->FirstChildElement("mimic");
      const std::string owner = "joint '" + j.name + "'";
      if (j.type == JointType::fixed) {
        r.warnings.push_back(line(j.name) + owner + ": fixed joint with <mimic joint=\"" +
                             j.mimic->written_leader + "\">: the mimic is ignored (the joint does "
                             "not move)");
        j.mimic.reset();
        continue;
      }
      if (j.type == JointType::floating) fail(at, owner + ": a floating joint cannot mimic");
    }
    for (Joint& j : r.joints) {
      if (!j.mimic) continue;
      const XMLElement* at = joint_at[j.name]->FirstChildElement("mimic");
      const std::string owner = "joint '" + j.name + "'";
      std::vector<std::string> chain{j.name};
      double multiplier = j.mimic->multiplier, offset = j.mimic->offset;
      std::string leader = j.mimic->written_leader;
      while (true) {
        const auto it = by_name.find(leader);
        if (it == by_name.end())
          fail(at, owner + ": <mimic joint=\"" + leader + "\">: no joint of that name" +
                       (chain.size() > 1 ? " (reached through the mimic chain from '" + j.name + "')" : "") +
                       "; name a revolute, continuous or prismatic joint of the file");
        const Joint& l = *it->second;
        if (std::find(chain.begin(), chain.end(), leader) != chain.end()) {
          std::string cycle;
          for (const auto& n : chain) cycle += "'" + n + "' -> ";
          fail(at, owner + ": mimic joints form a loop (" + cycle + "'" + leader +
                       "'): one of them must have a coordinate of its own; remove one <mimic>");
        }
        if (l.type != JointType::revolute && l.type != JointType::continuous &&
            l.type != JointType::prismatic)
          fail(at, owner + ": <mimic joint=\"" + leader + "\">: that joint is " +
                       (l.type == JointType::fixed ? "fixed" : "floating") +
                       ", not a one-degree-of-freedom joint (revolute, continuous, prismatic); "
                       "make it one, or drop the <mimic>");
        if (!l.mimic) break;
        // a → b → c: q_a = m_a (m_b q_c + o_b) + o_a
        chain.push_back(leader);
        offset = multiplier * l.mimic->offset + offset;
        multiplier = multiplier * l.mimic->multiplier;
        leader = l.mimic->written_leader;
      }
      j.mimic->leader = leader;
      j.mimic->multiplier = multiplier;
      j.mimic->offset = offset;
    }
    // A follower's <limit> bounds its leader's coordinate: q_f = m q + o within [lower, upper]
    // and |m q̇| within velocity. The coordinate's limits are those within which every joint it
    // moves keeps its own (its effort limit stays the leader's: the follower's torque is not the
    // coordinate's force); where they leave no position, the leader's own are kept, with a warning.
    for (const Joint& f : r.joints) {
      if (!f.mimic || f.mimic->multiplier == 0) continue;
      Joint& l = *by_name.at(f.mimic->leader);
      const double m = f.mimic->multiplier, o = f.mimic->offset;
      double lo = (f.lower - o) / m, hi = (f.upper - o) / m;
      if (m < 0) std::swap(lo, hi);
      const double lower = std::max(l.lower, lo), upper = std::min(l.upper, hi);
      if (lower > upper) {
        r.warnings.push_back(line(f.name) + "joint '" + f.name + "': its <limit> [" +
                             std::to_string(f.lower) + ", " + std::to_string(f.upper) +
                             "] cannot be met within the limits of its leader '" + l.name +
                             "' (it moves as multiplier * " + l.name + " + offset); the " +
                             "coordinate keeps the leader's own limits");
        continue;
      }
      l.lower = lower, l.upper = upper;
      l.velocity = std::min(l.velocity, f.velocity / std::abs(m));
    }
  }

  // Physically inconsistent inertias: a link welded to a fixed root cannot move and only gets a
  // warning; the others follow the policy. Negative or non-finite masses and inertias are always
  // errors (the reader refused them earlier, or does here).
  void check_inertias(Robot& r, std::map<std::string, const XMLElement*>& link_at,
                      InertiaPolicy policy) const {
    std::map<std::string, const Joint*> joint_to;
    for (const Joint& j : r.joints) joint_to[j.child] = &j;
    auto welded = [&](const std::string& link) {  // fixed joints only, up to a fixed root
      if (r.floating) return false;
      for (std::string l = link; l != r.root; l = joint_to[l]->parent)
        if (joint_to[l]->type != JointType::fixed) return false;
      return true;
    };
    for (Link& l : r.links) {
      if (!l.has_inertial) continue;
      const std::string problem = inertia_problem(l);
      if (problem.empty()) continue;
      const XMLElement* at = link_at[l.name]->FirstChildElement("inertial");
      if (const XMLElement* i = at->FirstChildElement("inertia")) at = i;
      const std::string owner = "link '" + l.name + "'";
      const std::string where = file_ + ":" + std::to_string(at->GetLineNum()) + ": " + owner + ": ";
      const bool fatal = problem.find("not finite") != std::string::npos ||
                         problem.find("negative mass") != std::string::npos;
      if (fatal) fail(at, owner + ": " + problem);
      if (welded(l.name)) {
        r.warnings.push_back(where + problem + "; the link is welded to the fixed root link '" +
                             r.root + "' (fixed joints only), so it does not enter the dynamics");
        continue;
      }
      switch (policy) {
        case InertiaPolicy::error:
          fail(at, owner + ": " + problem + "; to take the file as published, accept it with "
                   "add_eom_model(... INERTIA_POLICY warn) (eomgen-urdf --inertia warn) or "
                   "replace it by the nearest consistent inertia with INERTIA_POLICY nearest "
                   "(--inertia nearest)");
        case InertiaPolicy::warn:
          r.warnings.push_back(where + problem + "; accepted as written (inertia policy warn)");
          r.inconsistent_inertia = true;
          break;
        case InertiaPolicy::nearest: {
          const double change = nearest_inertia(l.inertial.inertia);
          r.warnings.push_back(where + problem + "; replaced by the nearest consistent inertia "
                               "(inertia policy nearest), relative change " + format(change) +
                               " (Frobenius norm)");
          if (const std::string still = inertia_problem(l); !still.empty())
            fail(at, owner + ": the nearest consistent inertia still fails: " + still);
          break;
        }
      }
    }
  }

  // A xacro file (ROS's XML macros: <xacro:property>, <xacro:macro>, <xacro:include>) is not URDF
  // until the xacro command expands it; read as URDF it would fail later with a misleading message
  // (no <link>, unknown links), so it is refused here, at its first xacro element. (The xacro
  // namespace alone is no sign: expanded files often keep its declaration.)
  static constexpr const char* expand_xacro =
      "Expand it first with the xacro command (ROS's, or `pip install xacro`): "
      "xacro robot.urdf.xacro > robot.urdf, then give that file";
  void refuse_xacro(const XMLElement* root) const {
    std::vector<const XMLElement*> stack{root};
    while (!stack.empty()) {
      const XMLElement* e = stack.back();
      stack.pop_back();
      if (std::string_view(e->Name()).rfind("xacro:", 0) == 0)
        fail(e, "this is a xacro file, not URDF: it has <" + std::string(e->Name()) + ">. " +
                    expand_xacro);
      std::vector<const XMLElement*> children;
      for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) children.push_back(c);
      stack.insert(stack.end(), children.rbegin(), children.rend());  // document order
    }
  }
  static bool declares_xacro(const XMLElement* root) {
    for (const tinyxml2::XMLAttribute* a = root->FirstAttribute(); a; a = a->Next())
      if (std::string_view(a->Name()).rfind("xmlns:", 0) == 0 &&
          std::string_view(a->Value()).find("xacro") != std::string_view::npos)
        return true;
    return false;
  }

 public:
  static std::string format(double x) {
    std::ostringstream s;
    s.precision(3);
    s << x;
    return s.str();
  }

 private:
  std::string file_;
};

}  // namespace

Robot parse(const std::string& text, const std::string& file, const ReadOptions& options) {
  return Reader(file).robot(text, options);
}
Robot parse(const std::string& text, const std::string& file, bool free_root) {
  return parse(text, file, ReadOptions{.free_root = free_root});
}

Robot read(const std::string& path, const ReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UrdfError(path + ": cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), path, options);
}
Robot read(const std::string& path, bool free_root) {
  return read(path, ReadOptions{.free_root = free_root});
}

}  // namespace eom::urdf
