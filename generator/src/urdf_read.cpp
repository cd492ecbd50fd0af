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

#include <tinyxml2.h>

#include <eom/body_check.hpp>

#include "eomgen/urdf.hpp"

namespace eom::urdf {

namespace {

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

  Link link(const XMLElement* e) const {
    Link l;
    l.name = attribute(e, "name", "a <link>");
    const std::string owner = "link '" + l.name + "'";
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
    SpatialBody<double> body;
    body.mass = l.inertial.mass;
    body.inertia = l.inertial.inertia;
    body.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (const std::string problem = body_problem(body); !problem.empty())
      fail(inertia, owner + ": " + problem);
    return l;
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
    if (e->FirstChildElement("mimic"))
      fail(e->FirstChildElement("mimic"),
           owner + ": <mimic> joints are not supported yet (planned: a holonomic constraint "
                   "q_joint = multiplier * q_other + offset); remove the mimic or model it as a "
                   "constraint by hand");
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
    }
    return j;
  }

  Robot robot(const std::string& text, bool free_root) const {
    tinyxml2::XMLDocument doc;
    if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS)
      throw UrdfError(file_ + ":" + std::to_string(doc.ErrorLineNum()) + ": malformed XML (" +
                      doc.ErrorName() + ")");
    const XMLElement* root = doc.RootElement();
    if (!root || std::string_view(root->Name()) != "robot")
      fail(root, "the top element must be <robot>");
    Robot r;
    r.file = file_;
    r.name = attribute(root, "name", "<robot>");
    std::map<std::string, const XMLElement*> link_at, joint_at;
    for (const XMLElement* e = root->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
      r.links.push_back(link(e));
      if (!link_at.emplace(r.links.back().name, e).second)
        fail(e, "link '" + r.links.back().name + "' is defined twice");
    }
    if (r.links.empty()) fail(root, "robot '" + r.name + "' has no <link>");
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
    return r;
  }

 private:
  std::string file_;
};

}  // namespace

Robot parse(const std::string& text, const std::string& file, bool free_root) {
  return Reader(file).robot(text, free_root);
}

Robot read(const std::string& path, bool free_root) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UrdfError(path + ": cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), path, free_root);
}

}  // namespace eom::urdf
