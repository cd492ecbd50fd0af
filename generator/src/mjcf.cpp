// MJCF import (eomgen/mjcf.hpp): MuJoCo compiles the file; what its mjModel says about the tree,
// the inertias, the joints, the passive forces and the actuators is written out as a model header
// in the tree form. Numbers are MuJoCo's compiled ones (body_pos/quat, body_ipos/iquat,
// body_inertia, jnt_pos/axis, qpos0, qpos_spring, dof_damping/armature, jnt_stiffness, opt.gravity,
// actuator_*), printed so that they read back exactly.
#include <mujoco/mujoco.h>

#include <fmt/format.h>
#include <tinyxml2.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "emit_detail.hpp"  // wrap, string_literal: as in generated code
#include "eomgen/mjcf.hpp"
#include "eomgen/urdf.hpp"  // identifier
#include "eom/contact/narrow_phase.hpp"  // eom::collides: the pairs the runtime models
#include "eom/multibody/scene.hpp"  // the structs' defaults

namespace eom::mjcf {

namespace {

// A double literal that reads back to exactly v.
std::string number(double v) {
  if (v == 0) v = 0.0;  // no -0.0
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".en") == std::string::npos) s += ".0";
  return s;
}

// A constant rigid transform x ↦ R x + t, R row-major (as MuJoCo's mju_quat2Mat gives it).
struct Pose {
  std::array<double, 9> R{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> t{0, 0, 0};
};
Pose compose(const Pose& a, const Pose& b) {  // a · b: b first
  Pose c;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)
      c.R[3 * i + j] =
          a.R[3 * i] * b.R[j] + a.R[3 * i + 1] * b.R[3 + j] + a.R[3 * i + 2] * b.R[6 + j];
    c.t[i] = a.R[3 * i] * b.t[0] + a.R[3 * i + 1] * b.t[1] + a.R[3 * i + 2] * b.t[2] + a.t[i];
  }
  return c;
}
Pose placed(const double* pos, const double* quat) {
  Pose x;
  mju_quat2Mat(x.R.data(), quat);
  for (int i = 0; i < 3; ++i) x.t[i] = pos[i];
  return x;
}
Pose shifted(const std::array<double, 3>& d) {
  Pose x;
  x.t = d;
  return x;
}
bool is_identity(const Pose& x) { return x.R == Pose{}.R && x.t == Pose{}.t; }
// {v0, v1, …}: n numbers as the header writes an array.
std::string numbers(const double* v, int n) {
  std::vector<std::string> items;
  for (int k = 0; k < n; ++k) items.push_back(number(v[k]));
  return fmt::format("{{{}}}", fmt::join(items, ", "));
}

// R column-major, as eom::Rot3 and the header hold it.
std::array<double, 9> column_major(const Pose& x) {
  std::array<double, 9> c;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) c[3 * j + i] = x.R[3 * i + j];
  return c;
}
// As the header writes it: at<S>({t}), or pose<S>({R column-major}, {t}).
std::string text(const Pose& x) {
  if (x.R == Pose{}.R) return fmt::format("at<S>({})", numbers(x.t.data(), 3));
  return fmt::format("pose<S>({}, {})", numbers(column_major(x).data(), 9), numbers(x.t.data(), 3));
}

// An eom::Softness field (eom/multibody/scene.hpp).
std::string softness(const double* solref, const double* solimp,
                     const std::string& field = "softness") {
  return fmt::format(".{} = {{.solref = {}, .solimp = {}}}", field, numbers(solref, mjNREF),
                     numbers(solimp, mjNIMP));
}

// The geom pairs MuJoCo's mj_collision (2.2) would test were every body near every other, in its
// order, as the fields of eom::CollisionPair: body pairs by signature, each body pair's geoms by
// id; a pair ordered by shape (MuJoCo's geom1 ≤ geom2 type); kept where a collision function
// exists and, unless a <pair> states it, where the contype/conaffinity test and the filters of
// bodies welded together and of welded parent and child pass and no <exclude> names the bodies;
// the <pair>s merged in where their body pair comes (opt.collision ALL), alone (PAIR), or left out
// (DYNAMIC). Contact parameters as mj_collideGeoms mixes them. A kept pair of shapes
// eom::collides does not model goes to `unmodeled` (which refuses it) before it is listed.
std::vector<std::vector<std::string>> collision_pairs(
    const mjModel* m, const std::function<void(int g1, int g2)>& unmodeled) {
  const bool override_params = m->opt.enableflags & mjENBL_OVERRIDE;
  const bool filter_parent = !(m->opt.disableflags & mjDSBL_FILTERPARENT);
  const int mode = m->opt.collision;
  std::vector<std::vector<std::string>> out;
  auto ordered = [&](int& g1, int& g2) {
    if (m->geom_type[g1] > m->geom_type[g2]) std::swap(g1, g2);
    return m->geom_type[g2] >= mjGEOM_SPHERE;  // MuJoCo's table: no plane or hfield pairs alone
  };
  auto add = [&](int g1, int g2, int condim, const std::array<double, 5>& friction, double margin,
                 double gap, const double* solref, const double* solimp) {
    if (!eom::collides(static_cast<eom::Shape>(m->geom_type[g1]),
                       static_cast<eom::Shape>(m->geom_type[g2])))
      unmodeled(g1, g2);
    std::array<double, 5> mu = friction;
    for (double& x : mu) x = std::max(x, mjMINMU);
    if (override_params) margin = m->opt.o_margin, solref = m->opt.o_solref, solimp = m->opt.o_solimp;
    const int b1 = m->geom_bodyid[g1], b2 = m->geom_bodyid[g2];
    const std::array<double, 2> weight{m->body_invweight0[2 * b1] + m->body_invweight0[2 * b2],
                                       m->body_invweight0[2 * b1 + 1] + m->body_invweight0[2 * b2 + 1]};
    out.push_back({fmt::format(".geom1 = {}", g1), fmt::format(".geom2 = {}", g2),
                   fmt::format(".condim = {}", condim), ".friction = " + numbers(mu.data(), 5),
                   fmt::format(".margin = {}", number(margin)), fmt::format(".gap = {}", number(gap)),
                   softness(solref, solimp), ".inverse_weight = " + numbers(weight.data(), 2)});
  };
  auto predefined = [&](int k) {
    int g1 = m->pair_geom1[k], g2 = m->pair_geom2[k];
    if (!ordered(g1, g2)) return;
    std::array<double, 5> friction;
    for (int i = 0; i < 5; ++i) friction[i] = m->pair_friction[5 * k + i];
    add(g1, g2, m->pair_dim[k], friction, m->pair_margin[k], m->pair_gap[k],
        m->pair_solref + mjNREF * k, m->pair_solimp + mjNIMP * k);
  };
  auto dynamic = [&](int g1, int g2) {
    if (!ordered(g1, g2)) return;
    const int w1 = m->body_weldid[m->geom_bodyid[g1]], w2 = m->body_weldid[m->geom_bodyid[g2]];
    if (!(m->geom_contype[g1] & m->geom_conaffinity[g2]) &&
        !(m->geom_contype[g2] & m->geom_conaffinity[g1]))
      return;
    if (w1 == w2) return;
    if (filter_parent && w1 && w2 &&
        (w1 == m->body_weldid[m->body_parentid[w2]] || w2 == m->body_weldid[m->body_parentid[w1]]))
      return;
    const int p1 = m->geom_priority[g1], p2 = m->geom_priority[g2];
    const int first = p1 > p2 ? g1 : g2;  // where the priorities differ, that geom's parameters
    std::array<double, 5> friction;
    std::array<double, mjNREF> solref;
    std::array<double, mjNIMP> solimp;
    int condim;
    if (p1 != p2) {
      condim = m->geom_condim[first];
      const double* f = m->geom_friction + 3 * first;
      friction = {f[0], f[0], f[1], f[2], f[2]};
      std::copy_n(m->geom_solref + mjNREF * first, mjNREF, solref.begin());
      std::copy_n(m->geom_solimp + mjNIMP * first, mjNIMP, solimp.begin());
    } else {
      condim = std::max(m->geom_condim[g1], m->geom_condim[g2]);
      std::array<double, 3> f;
      for (int i = 0; i < 3; ++i) f[i] = std::max(m->geom_friction[3 * g1 + i], m->geom_friction[3 * g2 + i]);
      friction = {f[0], f[0], f[1], f[2], f[2]};
      const double s1 = m->geom_solmix[g1], s2 = m->geom_solmix[g2];
      const double mix = s1 >= mjMINVAL && s2 >= mjMINVAL ? s1 / (s1 + s2)
                         : s1 < mjMINVAL && s2 < mjMINVAL ? 0.5
                         : s1 < mjMINVAL                  ? 0.0
                                                          : 1.0;
      const double* r1 = m->geom_solref + mjNREF * g1;
      const double* r2 = m->geom_solref + mjNREF * g2;
      for (int i = 0; i < mjNREF; ++i)  // standard (both positive): mixed; direct: the smaller
        solref[i] = r1[0] > 0 && r2[0] > 0 ? mix * r1[i] + (1 - mix) * r2[i] : std::min(r1[i], r2[i]);
      for (int i = 0; i < mjNIMP; ++i)
        solimp[i] = mix * m->geom_solimp[mjNIMP * g1 + i] + (1 - mix) * m->geom_solimp[mjNIMP * g2 + i];
    }
    add(g1, g2, condim, friction, std::max(m->geom_margin[g1], m->geom_margin[g2]),
        std::max(m->geom_gap[g1], m->geom_gap[g2]), solref.data(), solimp.data());
  };
  if (mode == mjCOL_PAIR) {
    for (int k = 0; k < m->npair; ++k) predefined(k);
    return out;
  }
  const bool merge = mode == mjCOL_ALL;
  int next_pair = 0;
  for (int b1 = 0; b1 < m->nbody; ++b1)
    for (int b2 = b1 + 1; b2 < m->nbody; ++b2) {
      const int signature = ((b1 + 1) << 16) + b2 + 1;
      const int first_pair = next_pair;
      while (merge && next_pair < m->npair && m->pair_signature[next_pair] <= signature)
        predefined(next_pair++);
      bool excluded = false;
      for (int k = 0; k < m->nexclude; ++k) excluded |= m->exclude_signature[k] == signature;
      if (excluded) continue;
      for (int g1 = m->body_geomadr[b1]; g1 < m->body_geomadr[b1] + m->body_geomnum[b1]; ++g1)
        for (int g2 = m->body_geomadr[b2]; g2 < m->body_geomadr[b2] + m->body_geomnum[b2]; ++g2) {
          bool stated = false;  // by a <pair> of this body pair, either way round
          for (int k = first_pair; k < next_pair; ++k)
            stated |= m->pair_signature[k] == signature &&
                      ((m->pair_geom1[k] == g1 && m->pair_geom2[k] == g2) ||
                       (m->pair_geom1[k] == g2 && m->pair_geom2[k] == g1));
          if (!stated) dynamic(g1, g2);
        }
    }
  while (merge && next_pair < m->npair) predefined(next_pair++);
  return out;
}

// MuJoCo's message on one line.
std::string one_line(std::string s) {
  std::string out;
  bool gap = false;
  for (char c : s) {
    if (c == '\n' || c == '\r') {
      gap = !out.empty();
      continue;
    }
    if (gap) out += "; ";
    gap = false;
    out += c;
  }
  return out;
}

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};

const char* joint_kind(int type) {
  switch (type) {
    case mjJNT_FREE:
      return "free";
    case mjJNT_BALL:
      return "ball";
    case mjJNT_SLIDE:
      return "slide";
    default:
      return "hinge";
  }
}

// Where an element refused is written: "<kind> '<name>'" looked up in the file (not in files it
// includes) by its tag and its parent's, or "option <attribute>[/<attribute>…]" as the <option>
// that sets one of them, for a message with a line. 0: not found.
int line_of(const std::string& path, const std::string& what) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) return 0;
  const bool option = what.rfind("option ", 0) == 0;
  const std::size_t open = what.find('\''), close = what.find('\'', open + 1);
  if (!option && (open == std::string::npos || close == std::string::npos)) return 0;
  const std::string kind = option ? "option" : what.substr(0, open - 1),
                    name = option ? what.substr(7) : what.substr(open + 1, close - open - 1);
  auto fits = [&](const tinyxml2::XMLElement* e) {
    if (option) {
      if (std::string_view(e->Name()) != "option") return false;
      for (std::size_t at = 0; at <= name.size();) {
        const std::size_t end = std::min(name.find('/', at), name.size());
        if (e->Attribute(name.substr(at, end - at).c_str())) return true;
        at = end + 1;
      }
      return false;
    }
    const char* n = e->Attribute("name");
    if (!n || name != n) return false;
    const std::string tag = e->Name();
    const std::string parent =
        e->Parent() && e->Parent()->ToElement() ? e->Parent()->ToElement()->Name() : "";
    if (kind == "joint") return (tag == "joint" || tag == "freejoint") && parent == "body";
    if (kind == "site") return tag == "site";
    if (kind == "geom" || kind == "body" || kind == "pair" || kind == "key") return tag == kind;
    return parent == kind;  // tendon, equality, actuator: their section's children
  };
  const tinyxml2::XMLElement* found = nullptr;
  auto walk = [&](auto&& self, const tinyxml2::XMLElement* e) -> void {
    for (; e && !found; e = e->NextSiblingElement()) {
      if (fits(e)) found = e;
      self(self, e->FirstChildElement());
    }
  };
  walk(walk, doc.RootElement());
  return found ? found->GetLineNum() : 0;
}

// Every number of the compiled model that the header writes must be one C++ reads back: MuJoCo
// 2.2 compiles some non-finite values (a geom's mass="inf" makes its body's mass and inertia inf
// and the invweight0s NaN), which would stop the header's build with a compiler's message or
// reach the kernels. Refused by the element, naming MuJoCo's field (found by the fuzz run,
// tests/mjcf/fuzz_mjcf.cpp).
template <class NameOf, class Refuse>
void require_finite(const mjModel& m, const NameOf& name_of, const Refuse& refuse) {
  auto check = [&](int type, int id, const char* kind, const char* field, const double* v, int n) {
    for (int k = 0; k < n; ++k)
      if (!std::isfinite(v[k]))
        refuse(fmt::format("{} '{}'", kind, name_of(type, id, fmt::format("{}{}", kind, id))),
               fmt::format("{} is {} as MuJoCo compiles it (from the element, its class's defaults or, "
                           "for a body's mass and inertia, its geoms); every number must be finite",
                           field, v[k]));
  };
  for (int b = 1; b < m.nbody; ++b) {
    auto body = [&](const char* field, const double* v, int n) { check(mjOBJ_BODY, b, "body", field, v + n * b, n); };
    body("pos", m.body_pos, 3), body("quat", m.body_quat, 4), body("ipos", m.body_ipos, 3);
    body("iquat", m.body_iquat, 4), body("mass", m.body_mass, 1), body("inertia", m.body_inertia, 3);
    body("invweight0", m.body_invweight0, 2);
  }
  for (int j = 0; j < m.njnt; ++j) {
    auto joint = [&](const char* field, const double* v, int n, int at) { check(mjOBJ_JOINT, j, "joint", field, v + at, n); };
    const int type = m.jnt_type[j];
    const int nq = type == mjJNT_FREE ? 7 : type == mjJNT_BALL ? 4 : 1, nv = type == mjJNT_FREE ? 6 : type == mjJNT_BALL ? 3 : 1;
    const int q = m.jnt_qposadr[j], v = m.jnt_dofadr[j];
    joint("pos", m.jnt_pos, 3, 3 * j), joint("axis", m.jnt_axis, 3, 3 * j), joint("range", m.jnt_range, 2, 2 * j);
    joint("stiffness", m.jnt_stiffness, 1, j), joint("margin", m.jnt_margin, 1, j);
    joint("solref", m.jnt_solref, mjNREF, mjNREF * j), joint("solimp", m.jnt_solimp, mjNIMP, mjNIMP * j);
    joint("qpos0", m.qpos0, nq, q), joint("springref", m.qpos_spring, nq, q);
    joint("damping", m.dof_damping, nv, v), joint("armature", m.dof_armature, nv, v);
    joint("frictionloss", m.dof_frictionloss, nv, v), joint("invweight0", m.dof_invweight0, nv, v);
    joint("solreffriction", m.dof_solref, mjNREF * nv, mjNREF * v);
    joint("solimpfriction", m.dof_solimp, mjNIMP * nv, mjNIMP * v);
  }
  for (int g = 0; g < m.ngeom; ++g) {
    auto geom = [&](const char* field, const double* v, int n) { check(mjOBJ_GEOM, g, "geom", field, v + n * g, n); };
    geom("size", m.geom_size, 3), geom("pos", m.geom_pos, 3), geom("quat", m.geom_quat, 4);
    geom("friction", m.geom_friction, 3), geom("margin", m.geom_margin, 1), geom("gap", m.geom_gap, 1);
    geom("solmix", m.geom_solmix, 1), geom("solref", m.geom_solref, mjNREF), geom("solimp", m.geom_solimp, mjNIMP);
    geom("rbound", m.geom_rbound, 1);
  }
  for (int s = 0; s < m.nsite; ++s) {
    check(mjOBJ_SITE, s, "site", "pos", m.site_pos + 3 * s, 3);
    check(mjOBJ_SITE, s, "site", "quat", m.site_quat + 4 * s, 4);
  }
  for (int a = 0; a < m.nu; ++a) {
    auto actuator = [&](const char* field, const double* v, int n) { check(mjOBJ_ACTUATOR, a, "actuator", field, v + n * a, n); };
    actuator("gear", m.actuator_gear, 6), actuator("gainprm", m.actuator_gainprm, mjNGAIN);
    actuator("biasprm", m.actuator_biasprm, mjNBIAS), actuator("ctrlrange", m.actuator_ctrlrange, 2);
    actuator("forcerange", m.actuator_forcerange, 2);
  }
  for (int t = 0; t < m.ntendon; ++t) {
    auto tendon = [&](const char* field, const double* v, int n) { check(mjOBJ_TENDON, t, "tendon", field, v + n * t, n); };
    tendon("stiffness", m.tendon_stiffness, 1), tendon("damping", m.tendon_damping, 1);
    tendon("springlength", m.tendon_lengthspring, 1), tendon("range", m.tendon_range, 2);
    tendon("margin", m.tendon_margin, 1), tendon("frictionloss", m.tendon_frictionloss, 1);
    tendon("solreflimit", m.tendon_solref_lim, mjNREF), tendon("solimplimit", m.tendon_solimp_lim, mjNIMP);
    tendon("solreffriction", m.tendon_solref_fri, mjNREF), tendon("solimpfriction", m.tendon_solimp_fri, mjNIMP);
    tendon("invweight0", m.tendon_invweight0, 1);
    check(mjOBJ_TENDON, t, "tendon", "coef", m.wrap_prm + m.tendon_adr[t], m.tendon_num[t]);
  }
  for (int e = 0; e < m.neq; ++e) {
    auto equality = [&](const char* field, const double* v, int n) { check(mjOBJ_EQUALITY, e, "equality", field, v + n * e, n); };
    equality("data", m.eq_data, mjNEQDATA), equality("solref", m.eq_solref, mjNREF);
    equality("solimp", m.eq_solimp, mjNIMP);
  }
  for (int p = 0; p < m.npair; ++p) {
    auto pair = [&](const char* field, const double* v, int n) { check(mjOBJ_PAIR, p, "pair", field, v + n * p, n); };
    pair("friction", m.pair_friction, 5), pair("margin", m.pair_margin, 1), pair("gap", m.pair_gap, 1);
    pair("solref", m.pair_solref, mjNREF), pair("solimp", m.pair_solimp, mjNIMP);
  }
  for (int k = 0; k < m.nkey; ++k) {
    auto key = [&](const char* field, const double* v, int n) { check(mjOBJ_KEY, k, "key", field, v + n * k, n); };
    key("time", m.key_time, 1), key("qpos", m.key_qpos, m.nq), key("qvel", m.key_qvel, m.nv);
    key("ctrl", m.key_ctrl, m.nu);
  }
  const mjOption& o = m.opt;
  auto option = [&](const char* field, const double* v, int n) {
    for (int k = 0; k < n; ++k)
      if (!std::isfinite(v[k]))
        refuse(fmt::format("option {}", field),
               fmt::format("{} as MuJoCo compiles it; every number must be finite", v[k]));
  };
  option("timestep", &o.timestep, 1), option("gravity", o.gravity, 3), option("impratio", &o.impratio, 1);
  option("tolerance", &o.tolerance, 1), option("noslip_tolerance", &o.noslip_tolerance, 1);
  option("o_margin", &o.o_margin, 1), option("o_solref", o.o_solref, mjNREF), option("o_solimp", o.o_solimp, mjNIMP);
}

// One link of the tree written out.
struct Link {
  std::string name, comment;
  int parent = -1;
  Pose origin;
  bool free = false, ball = false, prismatic = false;
  int coordinate = -1;  // qpos address; −1: fixed
  double offset = 0, armature = 0;
  std::array<double, 3> axis{0, 0, 1};
  bool massive = false;
  double mass = 0;
  std::array<double, 3> inertia{0, 0, 0};  // principal, in the inertial axes
  Pose inertial;
};

}  // namespace

std::vector<std::string> files_read(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::absolute(path).parent_path();
  std::vector<std::string> files;
  auto read = [&](auto&& self, const fs::path& file) -> void {
    const std::string name = fs::absolute(file).lexically_normal().string();
    if (std::find(files.begin(), files.end(), name) != files.end()) return;
    files.push_back(name);
    tinyxml2::XMLDocument doc;
    if (doc.LoadFile(name.c_str()) != tinyxml2::XML_SUCCESS) return;
    auto walk = [&](auto&& walk_, const tinyxml2::XMLElement* e) -> void {
      for (; e; e = e->NextSiblingElement()) {
        const char* f = e->Attribute("file");
        if (std::string_view(e->Name()) == "include" && f) self(self, folder / f);
        walk_(walk_, e->FirstChildElement());
      }
    };
    walk(walk, doc.RootElement());
  };
  read(read, path);
  return files;
}

std::string model_header(const std::string& path, const HeaderOptions& options,
                         std::vector<std::string>* warnings) {
  if (!std::filesystem::is_regular_file(path)) throw MjcfError(path + ": no such file");
  char error[1000] = "";
  std::unique_ptr<mjModel, ModelDeleter> owned(
      mj_loadXML(path.c_str(), nullptr, error, sizeof error));
  if (!owned) throw MjcfError(path + ": MuJoCo cannot load it: " + one_line(error));
  const mjModel* m = owned.get();
  auto name_of = [&](int type, int id, const std::string& fallback) {
    const char* n = mj_id2name(m, type, id);
    return n && *n ? std::string(n) : fallback;
  };
  auto refuse = [&](const std::string& what, const std::string& why) {
    const int line = line_of(path, what);
    throw MjcfError(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + what + ": " + why);
  };
  auto joint_name = [&](int j) { return name_of(mjOBJ_JOINT, j, fmt::format("joint{}", j)); };
  auto body_name = [&](int b) { return name_of(mjOBJ_BODY, b, fmt::format("body{}", b)); };
  auto actuator_name = [&](int a) {
    return name_of(mjOBJ_ACTUATOR, a, fmt::format("actuator{}", a));
  };
  const int disabled = m->opt.disableflags;
  const bool passive = !(disabled & mjDSBL_PASSIVE), actuation = !(disabled & mjDSBL_ACTUATION);
  const bool clamp_ctrl = !(disabled & mjDSBL_CLAMPCTRL);

  // What the tree form cannot say (yet): refused by name, before anything is written.
  // Fixed tendons are linear in q: their spring-dampers and actuators are generalized forces,
  // their limits and friction loss the scene's `tendons` (rows of eom::contact_step's solver); a
  // spatial one's length is a path through sites and around geoms.
  auto tendon_name = [&](int t) { return name_of(mjOBJ_TENDON, t, fmt::format("tendon{}", t)); };
  for (int t = 0; t < m->ntendon; ++t)
    for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
      const std::string what = fmt::format("tendon '{}'", tendon_name(t));
      if (m->wrap_type[w] != mjWRAP_JOINT)
        refuse(what, "a spatial tendon (through sites, around geoms) is not supported; fixed tendons are");
      const int j = m->wrap_objid[w], type = m->jnt_type[j];  // (MuJoCo 2.2 compiles any)
      if (type != mjJNT_HINGE && type != mjJNT_SLIDE)
        refuse(what, fmt::format("runs over the {} joint '{}': a fixed tendon's joints must be hinges "
                                 "or slides (its length is linear in their coordinates)",
                                 joint_kind(type), joint_name(j)));
    }
  static const char* equality_kinds[] = {"connect", "weld", "joint", "tendon", "distance"};
  auto equality_what = [&](int e) {
    const int type = m->eq_type[e];
    return fmt::format("equality '{}' ({})", name_of(mjOBJ_EQUALITY, e, fmt::format("equality{}", e)),
                       type >= 0 && type < 5 ? equality_kinds[type] : "?");
  };
  // (MuJoCo's compiler itself keeps joint equalities to hinges and slides.)
  for (int e = 0; e < m->neq; ++e) {
    const int type = m->eq_type[e];
    if (type != mjEQ_CONNECT && type != mjEQ_WELD && type != mjEQ_JOINT)
      refuse(equality_what(e), "only connect, weld and joint equalities are supported");
  }
  if (passive && (m->opt.density != 0 || m->opt.viscosity != 0))
    refuse("option density/viscosity", "fluid forces are not modeled; set both to 0");
  // eom::contact_step integrates as MuJoCo's Euler or RK4 (docs/CONTRACT.md §1).
  if (m->opt.integrator != mjINT_EULER && m->opt.integrator != mjINT_RK4)
    refuse("option integrator",
           "MuJoCo's implicit integrator is not supported by eom::contact_step; use Euler or RK4");
  require_finite(*m, name_of, refuse);
  const bool floating = m->njnt > 0 && m->jnt_type[0] == mjJNT_FREE;
  std::vector<int> quaternions;  // the q index of each unit quaternion's w (free and ball joints)
  for (int j = 0; j < m->njnt; ++j) {
    const std::string what = fmt::format("joint '{}'", joint_name(j));
    const int type = m->jnt_type[j], body = m->jnt_bodyid[j], dof = m->jnt_dofadr[j];
    // qvel's address: qpos's less one for each quaternion before it
    if (dof != m->jnt_qposadr[j] - static_cast<int>(quaternions.size()))
      refuse(what, "qpos and qvel addresses out of step (internal)");
    if (type == mjJNT_FREE || type == mjJNT_BALL)
      quaternions.push_back(m->jnt_qposadr[j] + (type == mjJNT_FREE ? 3 : 0));
    if (type == mjJNT_BALL) {
      for (int k = 0; k < 3; ++k)
        if (m->dof_armature[dof + k] != 0)
          refuse(what, "armature on a ball joint is not supported yet");
      if (m->jnt_stiffness[j] != 0 && passive)
        refuse(what, "stiffness on a ball joint is not supported yet");
      if (m->jnt_limited[j])
        refuse(what, "a limited ball joint (its cone limit) is not supported yet");
    }
    if (type == mjJNT_FREE) {
      if (m->body_jntnum[body] != 1) refuse(what, "a free joint shares its body with other joints");
      for (int k = 0; k < 6; ++k)
        if (m->dof_armature[dof + k] != 0)
          refuse(what, "armature on a free joint is not supported");
      if (m->jnt_stiffness[j] != 0 && passive)
        refuse(what, "stiffness on a free joint is not supported");
    } else if (type != mjJNT_BALL && m->dof_frictionloss[dof] != 0 && warnings) {
      warnings->push_back(
          fmt::format("{}: {}: frictionloss is a constraint of MuJoCo's solver, not part of "
                      "the dynamics (kept as data: friction_losses)",
                      path, what));
    }
  }
  for (int a = 0; a < m->nu; ++a) {
    const std::string what = fmt::format("actuator '{}'", actuator_name(a));
    if (m->actuator_dyntype[a] != mjDYN_NONE)
      refuse(what,
             "activation dynamics (dyntype) are not supported yet: act is not part of the state");
    const int trn = m->actuator_trntype[a];
    if (trn != mjTRN_JOINT && trn != mjTRN_JOINTINPARENT && trn != mjTRN_TENDON)
      refuse(what, trn == mjTRN_SITE          ? "a site transmission is not supported yet"
                   : trn == mjTRN_SLIDERCRANK ? "a slider-crank transmission is not supported yet"
                                              : "this transmission is not supported yet");
    if (trn != mjTRN_TENDON) {  // (a tendon's joints are hinges and slides, checked above)
      const int j = m->actuator_trnid[2 * a], type = m->jnt_type[j];
      if (type != mjJNT_HINGE && type != mjJNT_SLIDE)
        refuse(what, fmt::format("acts on the {} joint '{}': only hinge and slide joints are supported",
                                 joint_kind(type), joint_name(j)));
    }
    if (m->actuator_gaintype[a] != mjGAIN_FIXED && m->actuator_gaintype[a] != mjGAIN_AFFINE)
      refuse(what, "a muscle or user gain is not supported (fixed and affine are)");
    if (m->actuator_biastype[a] != mjBIAS_NONE && m->actuator_biastype[a] != mjBIAS_AFFINE)
      refuse(what, "a muscle or user bias is not supported (none and affine are)");
  }

  // The tree: per body with joints, one link per joint (the last carries the body), per body
  // without, a fixed link, or nothing where it is welded to the world.
  std::vector<Link> links;
  std::vector<int> body_link(m->nbody, -1);  // the link carrying the body; −1: the world
  std::vector<Pose> tail(m->nbody);          // the body frame in that link's frame (or the world's)
  for (int b = 1; b < m->nbody; ++b) {
    const int parent = m->body_parentid[b];
    const Pose X = compose(tail[parent], placed(m->body_pos + 3 * b, m->body_quat + 4 * b));
    const int on = body_link[parent], count = m->body_jntnum[b];
    if (count == 0 && on < 0) {  // welded to the world: a frame, not a link
      tail[b] = X;
      continue;
    }
    if (count == 0) {
      Link l;
      l.name = body_name(b);
      l.comment = "welded to its parent";
      l.parent = on;
      l.origin = X;
      links.push_back(l);
    } else if (m->jnt_type[m->body_jntadr[b]] == mjJNT_FREE) {
      Link l;
      l.name = body_name(b);
      l.comment = fmt::format("free joint '{}'", joint_name(m->body_jntadr[b]));
      l.free = true;
      l.coordinate = m->jnt_qposadr[m->body_jntadr[b]];
      links.push_back(l);
      tail[b] = Pose{};
    } else {
      std::array<double, 3> previous{0, 0, 0};  // the last joint's anchor (a slide's: none)
      for (int k = 0; k < count; ++k) {
        const int j = m->body_jntadr[b] + k, dof = m->jnt_dofadr[j], qa = m->jnt_qposadr[j];
        const bool slide = m->jnt_type[j] == mjJNT_SLIDE, ball = m->jnt_type[j] == mjJNT_BALL;
        std::array<double, 3> anchor{0, 0, 0};
        if (!slide) anchor = {m->jnt_pos[3 * j], m->jnt_pos[3 * j + 1], m->jnt_pos[3 * j + 2]};
        const Pose before = k == 0 ? X : shifted({-previous[0], -previous[1], -previous[2]});
        Link l;
        l.name = k + 1 == count ? body_name(b) : body_name(b) + ":" + joint_name(j);
        l.comment = fmt::format("{} '{}'", joint_kind(m->jnt_type[j]), joint_name(j));
        l.parent = k == 0 ? on : static_cast<int>(links.size()) - 1;
        l.origin = compose(before, shifted(anchor));
        l.prismatic = slide;
        l.ball = ball;  // turned by its quaternion itself (MuJoCo's qpos0 is not subtracted)
        l.coordinate = qa;
        if (!ball) {
          l.offset = -m->qpos0[qa];
          l.armature = m->dof_armature[dof];
          l.axis = {m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1], m->jnt_axis[3 * j + 2]};
        }
        if (k + 1 < count) l.comment += ", the body's next joint follows";
        links.push_back(l);
        previous = anchor;
      }
      tail[b] = shifted({-previous[0], -previous[1], -previous[2]});
    }
    body_link[b] = static_cast<int>(links.size()) - 1;
    Link& l = links.back();
    l.massive = m->body_mass[b] > 0 || m->body_inertia[3 * b] > 0 ||
                m->body_inertia[3 * b + 1] > 0 || m->body_inertia[3 * b + 2] > 0;
    l.mass = m->body_mass[b];
    l.inertia = {m->body_inertia[3 * b], m->body_inertia[3 * b + 1], m->body_inertia[3 * b + 2]};
    l.inertial = compose(tail[b], placed(m->body_ipos + 3 * b, m->body_iquat + 4 * b));
  }
  if (links.empty()) refuse("worldbody", "nothing moves: the model has no joint");

  // Names: coordinates as identifiers (a free joint's seven after it), inputs after the actuators.
  const std::string class_name =  // the model name is first in MuJoCo's names
      !options.class_name.empty()
          ? options.class_name
          : urdf::identifier(m->names[0] ? std::string(m->names) : "model", "model_");
  std::vector<std::string> coordinates;
  for (int j = 0; j < m->njnt; ++j) {
    const std::string id = urdf::identifier(joint_name(j), "joint_");
    if (m->jnt_type[j] == mjJNT_FREE)
      for (const char* suffix : {"_x", "_y", "_z", "_qw", "_qx", "_qy", "_qz"})
        coordinates.push_back(id + suffix);
    else if (m->jnt_type[j] == mjJNT_BALL)
      for (const char* suffix : {"_qw", "_qx", "_qy", "_qz"}) coordinates.push_back(id + suffix);
    else
      coordinates.push_back(id);
  }
  std::vector<std::string> inputs;
  for (int a = 0; a < m->nu; ++a) inputs.push_back(urdf::identifier(actuator_name(a), "actuator_"));
  for (const auto* names : {&coordinates, &inputs}) {
    std::set<std::string> seen;
    for (const std::string& n : *names)
      if (!seen.insert(n).second)
        refuse(fmt::format("{} '{}'", names == &inputs ? "actuator" : "joint", n),
               "two names become this identifier; rename one");
  }
  if (static_cast<int>(coordinates.size()) != m->nq) refuse("model", "nq out of step (internal)");

  // Gravity: along −z (a parameter g), else its three components.
  const double* gravity = m->opt.gravity;
  const bool no_gravity = disabled & mjDSBL_GRAVITY;
  const bool vertical = gravity[0] == 0 && gravity[1] == 0;
  std::vector<std::string> parameters;
  std::vector<std::string> values;
  if (vertical) {
    parameters = {"g"};
    values = {number(no_gravity ? 0.0 : -gravity[2])};
  } else {
    parameters = {"gravity_x", "gravity_y", "gravity_z"};
    for (int k = 0; k < 3; ++k) values.push_back(number(no_gravity ? 0.0 : gravity[k]));
  }

  // Frames: every named body (but the world), then every named site.
  struct Frame {
    std::string name;
    int link;
    Pose offset;
  };
  std::vector<Frame> frames;
  std::set<std::string> frame_seen;
  for (int b = 1; b < m->nbody; ++b) {
    const char* n = mj_id2name(m, mjOBJ_BODY, b);
    if (!n || !*n) continue;
    frames.push_back({n, body_link[b], tail[b]});
    frame_seen.insert(n);
  }
  for (int s = 0; s < m->nsite; ++s) {
    const char* n = mj_id2name(m, mjOBJ_SITE, s);
    if (!n || !*n) continue;
    if (!frame_seen.insert(n).second)
      refuse(fmt::format("site '{}'", n),
             "a body has this name too, so FRAMES could not tell them apart; rename one");
    const int b = m->site_bodyid[s];
    frames.push_back(
        {n, body_link[b], compose(tail[b], placed(m->site_pos + 3 * s, m->site_quat + 4 * s))});
  }

  // Equality constraints as the model's holonomic constraints φ(q) = 0, row for row MuJoCo's
  // (mj_instantiateEquality): connect, the anchors' difference (body1's − body2's, world axes);
  // weld, that and the vector part of the quaternion of q2⁻¹ q1 relpose; joint, q1 − q1₀ − poly(q2 −
  // q2₀). MuJoCo holds them softly (solref, solimp), the model exactly. Inactive ones are left out.
  std::vector<std::string> constraint_rows, constraint_lines;
  bool constraint_uses_tree = false;
  std::vector<std::vector<std::string>> equality_softness;  // fields of eom::EqualitySoftness
  for (int e = 0; e < m->neq; ++e) {
    if (!m->eq_active[e]) {
      if (warnings)
        warnings->push_back(fmt::format("{}: {}: inactive (active=\"false\"): left out of the "
                                        "model's constraints", path, equality_what(e)));
      continue;
    }
    const std::string id =
        urdf::identifier(name_of(mjOBJ_EQUALITY, e, fmt::format("equality{}", e)), "equality_");
    const double* data = m->eq_data + mjNEQDATA * e;
    const int at = static_cast<int>(constraint_rows.size()), b1 = m->eq_obj1id[e],
              b2 = m->eq_obj2id[e], type = m->eq_type[e];
    equality_softness.push_back(
        {fmt::format(".name = {}", gen::detail::string_literal(
                                       name_of(mjOBJ_EQUALITY, e, fmt::format("equality{}", e)))),
         fmt::format(".first = {}", at),
         fmt::format(".rows = {}", type == mjEQ_CONNECT ? 3 : type == mjEQ_WELD ? 6 : 1),
         softness(m->eq_solref + mjNREF * e, m->eq_solimp + mjNIMP * e)});
    // MuJoCo's efc_diagApprox of its rows (mj_diagApprox; a weld's rotation rows too take the
    // translational weights there), and a weld's torquescale (its rotation rows' Jacobian).
    const double weight =
        type != mjEQ_JOINT ? m->body_invweight0[2 * b1] + m->body_invweight0[2 * b2]
                           : m->dof_invweight0[m->jnt_dofadr[b1]] +
                                 (b2 >= 0 ? m->dof_invweight0[m->jnt_dofadr[b2]] : 0.0);
    equality_softness.back().push_back(fmt::format(".inverse_weight = {}", number(weight)));
    if (type == mjEQ_WELD && data[10] != 1)
      equality_softness.back().push_back(fmt::format(".torquescale = {}", number(data[10])));
    if (type == mjEQ_JOINT) {
      const int a1 = m->jnt_qposadr[b1];
      auto offset = [](int a, double by) {  // q[a] − by
        return by == 0 ? fmt::format("q[{}]", a) : fmt::format("q[{}] - {}", a, number(by));
      };
      std::string expr = offset(a1, m->qpos0[a1] + data[0]);
      if (b2 >= 0) {
        const int a2 = m->jnt_qposadr[b2];
        std::string poly;  // Horner: c1 + dif (c2 + dif (c3 + dif c4))
        for (int k = 4; k >= 1; --k)
          if (data[k] != 0 || !poly.empty())
            poly = poly.empty() ? number(data[k])
                                : fmt::format("{} + dif * ({})", number(data[k]), poly);
        if (!poly.empty())
          expr = fmt::format("{} - dif * ({})", expr, poly);
        constraint_lines.push_back(
            fmt::format("    {{  // {}: '{}' against '{}'", equality_what(e), joint_name(b1),
                        joint_name(b2)));
        constraint_lines.push_back(fmt::format("      const S dif = {};", offset(a2, m->qpos0[a2])));
        constraint_lines.push_back(fmt::format("      phi[{}] = {};", at, expr));
        constraint_lines.push_back("    }");
      } else {
        constraint_lines.push_back(fmt::format("    phi[{}] = {};  // {}: '{}' held", at, expr,
                                               equality_what(e), joint_name(b1)));
      }
      constraint_rows.push_back(id);
      continue;
    }
    // The two frames, each on the link carrying its body (or the world): body1's at its anchor,
    // turned by relpose for a weld; body2's at its anchor.
    const bool weld = type == mjEQ_WELD;
    const double* anchor1 = weld ? data + 3 : data;
    const double* anchor2 = weld ? data : data + 3;
    Pose on1 = compose(tail[b1], shifted({anchor1[0], anchor1[1], anchor1[2]}));
    Pose on2 = compose(tail[b2], shifted({anchor2[0], anchor2[1], anchor2[2]}));
    if (weld) {
      std::array<double, 4> relpose{data[6], data[7], data[8], data[9]};
      mju_normalize4(relpose.data());
      on1 = compose(tail[b1], placed(anchor1, relpose.data()));
    } else {
      on1.R = on2.R = Pose{}.R;  // points: only their origins count
    }
    auto frame = [&](int b, const Pose& x) {
      if (body_link[b] < 0) return text(x);
      constraint_uses_tree = true;
      return is_identity(x) ? fmt::format("X[{}]", body_link[b])
                            : fmt::format("X[{}] * {}", body_link[b], text(x));
    };
    constraint_lines.push_back(fmt::format("    // {}: body '{}' against {}", equality_what(e),
                                           body_name(b1),
                                           b2 > 0 ? "body '" + body_name(b2) + "'" : "the world"));
    constraint_lines.push_back(
        gen::detail::wrap("    eom::frame_coincidence<S>(",
                          {frame(b1, on1), frame(b2, on2),
                           fmt::format("phi.subspan({}, {})", at, weld ? 6 : 3)},
                          ");"));
    for (const char* suffix : {"_x", "_y", "_z", "_rx", "_ry", "_rz"}) {
      if (!weld && suffix[1] == 'r') break;
      constraint_rows.push_back(id + suffix);
    }
  }

  {
    std::set<std::string> seen;
    for (const std::string& n : constraint_rows)
      if (!seen.insert(n).second)
        refuse(fmt::format("equality '{}'", n), "two equalities' rows get this name; rename one");
  }

  // Generalized forces, as lines of C++: passive, then actuators.
  std::vector<std::string> force_lines;
  std::vector<std::pair<int, double>> rotors;  // coordinate, armature
  for (const Link& l : links)
    if (l.armature != 0) rotors.emplace_back(l.coordinate, l.armature);
  for (int j = 0; j < m->njnt && passive; ++j) {
    const int dof = m->jnt_dofadr[j], qa = m->jnt_qposadr[j];
    const int ndof = m->jnt_type[j] == mjJNT_FREE ? 6 : m->jnt_type[j] == mjJNT_BALL ? 3 : 1;
    for (int k = 0; k < ndof; ++k) {
      std::string terms;
      if (m->dof_damping[dof + k] != 0)
        terms += fmt::format(" - {} * qd[{}]", number(m->dof_damping[dof + k]), dof + k);
      if (ndof == 1 && m->jnt_stiffness[j] != 0) {
        const double ref = m->qpos_spring[qa];
        terms += ref == 0 ? fmt::format(" - {} * q[{}]", number(m->jnt_stiffness[j]), qa)
                          : fmt::format(" - {} * (q[{}] - {})", number(m->jnt_stiffness[j]), qa,
                                        number(ref));
      }
      if (!terms.empty())
        force_lines.push_back(fmt::format("    Q[{0}] = Q[{0}]{1};  // joint '{2}': passive",
                                          dof + k, terms, joint_name(j)));
    }
  }
  // A fixed tendon's length Σ coef q (or rate, Σ coef v) as MuJoCo sums it, and the generalized
  // force of a force f along it: Q += J' f with J's entries `scale` · coef (MuJoCo's moment).
  auto tendon_sum = [&](int t, bool rate) {
    std::vector<std::string> terms;
    for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
      const int j = m->wrap_objid[w];
      terms.push_back(fmt::format("{} * {}[{}]", number(m->wrap_prm[w]), rate ? "qd" : "q",
                                  rate ? m->jnt_dofadr[j] : m->jnt_qposadr[j]));
    }
    return fmt::format("{}", fmt::join(terms, " + "));
  };
  auto along_tendon = [&](int t, double scale, const std::string& f, const std::string& comment) {
    force_lines.push_back(fmt::format("    {{  // {}", comment));
    force_lines.push_back(fmt::format("      const S f = {};", f));
    for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
      const int dof = m->jnt_dofadr[m->wrap_objid[w]];
      force_lines.push_back(fmt::format("      Q[{0}] = Q[{0}] + {1} * f;", dof, number(scale * m->wrap_prm[w])));
    }
    force_lines.push_back("    }");
  };
  for (int t = 0; t < m->ntendon && passive; ++t) {  // MuJoCo's mj_passive: its spring-damper
    const double k = m->tendon_stiffness[t], b = m->tendon_damping[t];
    if (k == 0 && b == 0) continue;
    std::vector<std::string> f;
    if (k != 0)
      f.push_back(fmt::format("{} * ({} - {})", number(-k), tendon_sum(t, false), number(m->tendon_lengthspring[t])));
    if (b != 0) f.push_back(fmt::format("{} * ({})", number(-b), tendon_sum(t, true)));
    along_tendon(t, 1.0, fmt::format("{}", fmt::join(f, " + ")), fmt::format("tendon '{}': passive", tendon_name(t)));
  }
  for (int a = 0; a < m->nu && actuation; ++a) {
    const bool on_tendon = m->actuator_trntype[a] == mjTRN_TENDON;
    const int j = on_tendon ? -1 : m->actuator_trnid[2 * a], tendon = on_tendon ? m->actuator_trnid[2 * a] : -1;
    const int dof = on_tendon ? -1 : m->jnt_dofadr[j], qa = on_tendon ? -1 : m->jnt_qposadr[j];
    const double gear = m->actuator_gear[6 * a];
    const std::string length = on_tendon ? fmt::format("{} * ({})", number(gear), tendon_sum(tendon, false))
                                         : fmt::format("{} * q[{}]", number(gear), qa);
    const std::string velocity = on_tendon ? fmt::format("{} * ({})", number(gear), tendon_sum(tendon, true))
                                           : fmt::format("{} * qd[{}]", number(gear), dof);
    auto affine = [&](const double* k, bool with_rates) {  // k0 + k1 · length + k2 · velocity
      std::vector<std::string> t;
      if (k[0] != 0 || !with_rates) t.push_back(number(k[0]));
      if (with_rates && k[1] != 0) t.push_back(fmt::format("{} * ({})", number(k[1]), length));
      if (with_rates && k[2] != 0) t.push_back(fmt::format("{} * ({})", number(k[2]), velocity));
      return t;
    };
    const double* lim = m->actuator_ctrlrange + 2 * a;
    const std::string ctrl =
        clamp_ctrl && m->actuator_ctrllimited[a]
            ? fmt::format("clamp(u[{}], {}, {})", a, number(lim[0]), number(lim[1]))
            : fmt::format("u[{}]", a);
    const auto gain =
        affine(m->actuator_gainprm + mjNGAIN * a, m->actuator_gaintype[a] == mjGAIN_AFFINE);
    std::vector<std::string> force;
    if (!gain.empty() && !(gain.size() == 1 && gain[0] == "0.0"))
      force.push_back(gain.size() == 1 && gain[0] == "1.0" ? ctrl
                      : gain.size() == 1                   ? fmt::format("{} * {}", gain[0], ctrl)
                                         : fmt::format("({}) * {}", fmt::join(gain, " + "), ctrl));
    if (m->actuator_biastype[a] == mjBIAS_AFFINE)
      for (const std::string& t : affine(m->actuator_biasprm + mjNBIAS * a, true))
        if (t != "0.0") force.push_back(t);
    if (force.empty()) continue;
    std::string f = fmt::format("{}", fmt::join(force, " + "));
    if (m->actuator_forcelimited[a]) {
      const double* fl = m->actuator_forcerange + 2 * a;
      f = fmt::format("clamp({}, {}, {})", f, number(fl[0]), number(fl[1]));
    }
    if (on_tendon)
      along_tendon(tendon, gear, f, fmt::format("actuator '{}' on tendon '{}'", actuator_name(a), tendon_name(tendon)));
    else
      force_lines.push_back(
          fmt::format("    Q[{0}] = Q[{0}] + {1} * ({2});  // actuator '{3}' on '{4}'", dof,
                      number(gear), f, actuator_name(a), joint_name(j)));
  }

  // The header.
  fmt::memory_buffer out;
  auto line = [&](std::string_view s) {
    out.append(s);
    out.push_back('\n');
  };
  auto array = [](const std::string& head, const std::vector<std::string>& items, bool quoted) {
    std::vector<std::string> shown;
    for (const std::string& s : items) shown.push_back(quoted ? gen::detail::string_literal(s) : s);
    return gen::detail::wrap("  static constexpr " + head + "{", shown, "};");
  };
  line(fmt::format("// Generated by eomgen-mjcf from {} (MuJoCo {} compiled it): do not edit.",
                   std::filesystem::path(path).filename().string(), mj_versionString()));
  line("// The tree form (eom/multibody/tree.hpp, docs/CONTRACT.md §1, MJCF):");
  line(
      "//   q, v         MuJoCo's qpos and qvel (a free joint: x y z qw qx qy qz; world linear and "
      "body");
  line("//                angular velocity); u: MuJoCo's ctrl, one per actuator");
  line(
      "//   tree         per MuJoCo body one link per joint (the last carries the body), or a "
      "fixed link");
  line("//   forces       Q = sum gear * force(ctrl) - damping * v - stiffness * (q - springref), and");
  line("//                each fixed tendon's spring-damper and actuators along its coefficients;");
  line("//                armature on M's diagonal; gravity from <option gravity>");
  line("#pragma once");
  line("");
  line("#include <array>");
  line("#include <limits>");
  line("");
  line("#include <eom/model/model.hpp>");
  if (constraint_uses_tree) line("#include <eom/multibody/frames.hpp>");
  line("#include <eom/multibody/scene.hpp>");
  line("#include <eom/multibody/tree.hpp>");
  line("");
  line(fmt::format("namespace {} {{", options.ns));
  line("");
  line(fmt::format("struct {} {{", class_name));
  line(array("std::array coordinates", coordinates, true));
  if (floating)
    line(
        "  static constexpr bool floating_base = true;  // q[0..7): the free joint "
        "(eom/model/free_joint.hpp)");
  if (quaternions.size() > (floating ? 1u : 0u)) {
    std::vector<std::string> at;
    for (int i : quaternions) at.push_back(std::to_string(i));
    line("  // The q index of each unit quaternion's w: free joints' (x y z first) and ball joints'.");
    line(array("std::array quaternions", at, false));
  }
  if (!inputs.empty()) line(array("std::array inputs", inputs, true));
  line(array("std::array parameters", parameters, true));
  line(array(fmt::format("std::array<double, {}> parameter_values", values.size()), values, false));
  {  // joint ranges where limited: data (MuJoCo enforces them as constraints; the model does not)
    std::vector<std::string> lower, upper;
    for (int j = 0; j < m->njnt; ++j) {
      const bool limited = m->jnt_limited[j] && m->jnt_type[j] != mjJNT_FREE;
      const int n = m->jnt_type[j] == mjJNT_FREE ? 7 : m->jnt_type[j] == mjJNT_BALL ? 4 : 1;
      for (int k = 0; k < n; ++k) {
        lower.push_back(limited ? number(m->jnt_range[2 * j]) : "-unlimited");
        upper.push_back(limited ? number(m->jnt_range[2 * j + 1]) : "unlimited");
      }
    }
    line(
        "  // The joints' ranges (radians or metres) where limited, else +-unlimited: data, not "
        "dynamics.");
    line("  static constexpr double unlimited = std::numeric_limits<double>::infinity();");
    line(array(fmt::format("std::array<double, {}> position_lower", m->nq), lower, false));
    line(array(fmt::format("std::array<double, {}> position_upper", m->nq), upper, false));
  }
  line(fmt::format("  static constexpr int link_count = {};", links.size()));
  line(rotors.empty()
           ? "  static constexpr int body_count = link_count;  // one body per link"
           : fmt::format("  static constexpr int body_count = link_count + {};  // and a rotor per "
                         "joint with armature",
                         rotors.size()));
  std::vector<std::string> link_names;
  for (const Link& l : links) link_names.push_back(l.name);
  line(array("std::array tree_links", link_names, true));
  line("");
  line("  // A constant pose: rotation (column-major) and translation.");
  line("  template <class S>");
  line(
      "  static eom::Transform<S> pose(const std::array<double, 9>& r, const std::array<double, "
      "3>& t) {");
  line("    eom::Transform<S> x;");
  line("    for (int k = 0; k < 9; ++k) x.rotation[k] = S(r[k]);");
  line("    for (int k = 0; k < 3; ++k) x.translation[k] = S(t[k]);");
  line("    return x;");
  line("  }");
  line("  template <class S> static eom::Transform<S> at(const std::array<double, 3>& t) {");
  line("    return pose<S>({1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, t);");
  line("  }");
  line("  // x within [lo, hi] (MuJoCo's ctrlrange and forcerange).");
  line("  template <class S> static S clamp(const S& x, double lo, double hi) {");
  line("    return eom::select(x < S(lo), S(lo), eom::select(S(hi) < x, S(hi), x));");
  line("  }");
  line("");
  line("  template <class S> static void tree(eom::In<S>, eom::Out<eom::TreeLink<S>> l) {");
  for (std::size_t k = 0; k < links.size(); ++k) {
    const Link& l = links[k];
    std::vector<std::string> fields{fmt::format(".parent = {}", l.parent)};
    if (!is_identity(l.origin)) fields.push_back(".origin = " + text(l.origin));
    if (l.coordinate >= 0) fields.push_back(fmt::format(".coordinate = {}", l.coordinate));
    if (l.offset != 0) fields.push_back(fmt::format(".offset = {}", number(l.offset)));
    if (l.free) fields.push_back(".free = true");
    if (l.ball) fields.push_back(".ball = true");
    if (!l.free && !l.ball && l.coordinate >= 0) {
      if (l.prismatic) fields.push_back(".prismatic = true");
      fields.push_back(".axis = " + numbers(l.axis.data(), 3));
      if (l.armature != 0) fields.push_back(fmt::format(".armature = {}", number(l.armature)));
    }
    if (l.massive) {
      fields.push_back(fmt::format(".mass = S({})", number(l.mass)));
      fields.push_back(fmt::format(".inertia = {{S({}), S({}), S({}), S(0), S(0), S(0)}}",
                                   number(l.inertia[0]), number(l.inertia[1]),
                                   number(l.inertia[2])));
      if (!is_identity(l.inertial)) fields.push_back(".inertial = " + text(l.inertial));
    }
    line(fmt::format("    // body '{}': {}{}", l.name, l.comment, l.massive ? "" : " (massless)"));
    line(gen::detail::wrap(fmt::format("    l[{}] = {{", k), fields, "};"));
  }
  line("  }");
  line("");
  std::vector<std::string> frame_literals;
  for (const Frame& f : frames) frame_literals.push_back(gen::detail::string_literal(f.name));
  if (!frames.empty()) {
    line(
        "  // The named bodies, then the named sites: on the link that carries them, or on the "
        "world.");
    line(gen::detail::wrap("  static constexpr std::array frame_names{", frame_literals, "};"));
    line(
        "  template <class S> static void link_frames(eom::In<S>, eom::Out<eom::LinkFrame<S>> f) "
        "{");
    for (std::size_t k = 0; k < frames.size(); ++k) {
      std::vector<std::string> fields{fmt::format(".link = {}", frames[k].link)};
      if (!is_identity(frames[k].offset)) fields.push_back(".offset = " + text(frames[k].offset));
      line(gen::detail::wrap(fmt::format("    f[{}] = {{", k), fields, "};"));
    }
    line("  }");
    line("");
  }
  if (!constraint_rows.empty()) {
    line(
        "  // MuJoCo's equality constraints, held exactly (MuJoCo's solver holds them softly): "
        "phi(q) = 0,");
    line("  // row for row as MuJoCo states them (docs/CONTRACT.md §1, MJCF).");
    line(array("std::array constraint_names", constraint_rows, true));
    line(fmt::format("  template <class S> static void constraints(eom::In<S> q, eom::In<S>{}, "
                     "eom::Out<S> phi) {{",
                     constraint_uses_tree ? " p" : ""));
    if (constraint_uses_tree) {
      line("    std::array<eom::TreeLink<S>, link_count> l;");
      line("    tree<S>(p, l);");
      line("    const auto X = eom::tree_placements<S>(l, q);");
    }
    for (const std::string& s : constraint_lines) line(s);
    line("  }");
    line("");
  }
  // The scene as data (eom/multibody/scene.hpp), for simulation with contact: geoms placed on the
  // links as frames are; a geom's optional fields where they are not the struct's defaults.
  // static constexpr std::array<type, n> name{{ {fields}, … }};
  auto entries = [&](const std::string& type, const std::string& name,
                     const std::vector<std::vector<std::string>>& items) {
    out.append(gen::detail::scene_table(type, name, items));
  };
  line("  // The scene as data (eom/multibody/scene.hpp: geoms on the links, joint limits, friction");
  line("  // loss, the equalities' softness, <option>, keyframes), MuJoCo's compiled values; the");
  line("  // dynamics above do not use them.");
  {
    static const char* shapes[] = {"plane",     "hfield",   "sphere", "capsule",
                                   "ellipsoid", "cylinder", "box",    "mesh"};
    const eom::Geom defaults;
    std::vector<std::vector<std::string>> geoms;
    for (int g = 0; g < m->ngeom; ++g) {
      const int type = m->geom_type[g], b = m->geom_bodyid[g];
      if (type < 0 || type > mjGEOM_MESH)
        refuse(fmt::format("geom '{}'", name_of(mjOBJ_GEOM, g, fmt::format("geom{}", g))),
               "a geom type eom::Shape does not have");
      const Pose at = compose(tail[b], placed(m->geom_pos + 3 * g, m->geom_quat + 4 * g));
      std::vector<std::string> f;
      const char* n = mj_id2name(m, mjOBJ_GEOM, g);
      if (n && *n) f.push_back(".name = " + gen::detail::string_literal(n));
      f.push_back(fmt::format(".shape = eom::Shape::{}", shapes[type]));
      f.push_back(fmt::format(".link = {}", body_link[b]));
      f.push_back(".size = " + numbers(m->geom_size + 3 * g, 3));
      if (at.R != Pose{}.R) f.push_back(".rotation = " + numbers(column_major(at).data(), 9));
      if (at.t != Pose{}.t) f.push_back(".position = " + numbers(at.t.data(), 3));
      f.push_back(".friction = " + numbers(m->geom_friction + 3 * g, 3));
      auto integer = [&](const char* field, int v, int standard) {
        if (v != standard) f.push_back(fmt::format(".{} = {}", field, v));
      };
      auto real = [&](const char* field, double v, double standard) {
        if (v != standard) f.push_back(fmt::format(".{} = {}", field, number(v)));
      };
      integer("condim", m->geom_condim[g], defaults.condim);
      integer("contype", m->geom_contype[g], defaults.contype);
      integer("conaffinity", m->geom_conaffinity[g], defaults.conaffinity);
      integer("priority", m->geom_priority[g], defaults.priority);
      real("solmix", m->geom_solmix[g], defaults.solmix);
      real("margin", m->geom_margin[g], defaults.margin);
      real("gap", m->geom_gap[g], defaults.gap);
      f.push_back(softness(m->geom_solref + mjNREF * g, m->geom_solimp + mjNIMP * g));
      real("rbound", m->geom_rbound[g], defaults.rbound);
      geoms.push_back(f);
    }
    entries("eom::Geom", "geoms", geoms);
    // A candidate pair the narrow phase does not model stops the build, naming the geom that
    // makes it so (a cylinder, an ellipsoid, a mesh or a height field) and the way out.
    auto unmodeled = [&](int g1, int g2) {
      auto shape = [&](int g) { return shapes[m->geom_type[g]]; };
      auto geom = [&](int g) {
        const char* n = mj_id2name(m, mjOBJ_GEOM, g);
        return n && *n ? fmt::format("geom '{}'", n)
                       : fmt::format("geom {} (unnamed, on body '{}')", g, body_name(m->geom_bodyid[g]));
      };
      auto hard = [&](int g) { return m->geom_type[g] != mjGEOM_PLANE && m->geom_type[g] != mjGEOM_SPHERE &&
                                      m->geom_type[g] != mjGEOM_CAPSULE && m->geom_type[g] != mjGEOM_BOX; };
      const int named = hard(g1) ? g1 : g2, other = named == g1 ? g2 : g1;
      const int type1 = m->geom_type[g1], type2 = m->geom_type[g2];
      const std::string why =
          type1 == mjGEOM_HFIELD || type2 == mjGEOM_HFIELD
              ? "height fields are not supported (MuJoCo collides them by libccd's MPR)"
          : type1 == mjGEOM_PLANE && type2 == mjGEOM_MESH
              ? "meshes are not supported (the header does not carry their vertices)"
              : fmt::format("MuJoCo 2.2 finds {}–{} contacts by libccd's iterative MPR (mjc_Convex), "
                            "which eomgen does not reproduce (closed forms: the plane, sphere, "
                            "capsule and box pairs, plane–ellipsoid, plane–cylinder)",
                            shape(g1), shape(g2));
      const std::string kind = shape(named);
      refuse(geom(named),
             fmt::format("{} {} against {} ({}): {}; leave the pair out (<exclude body1=\"{}\" "
                         "body2=\"{}\"/>, contype/conaffinity, or, for a <pair>, remove it) or "
                         "let a capsule, sphere or box stand in for the {}",
                         kind[0] == 'e' ? "an" : "a", kind, geom(other), shape(other), why,
                         body_name(m->geom_bodyid[g1]), body_name(m->geom_bodyid[g2]),
                         shape(named)));
    };
    entries("eom::CollisionPair", "collision_pairs", collision_pairs(m, unmodeled));

    std::vector<std::vector<std::string>> limits, losses;
    for (int j = 0; j < m->njnt; ++j) {
      if (!m->jnt_limited[j] || m->jnt_type[j] == mjJNT_FREE) continue;
      limits.push_back({".joint = " + gen::detail::string_literal(joint_name(j)),
                        fmt::format(".coordinate = {}", m->jnt_qposadr[j]),
                        fmt::format(".velocity = {}", m->jnt_dofadr[j]),
                        fmt::format(".lower = {}", number(m->jnt_range[2 * j])),
                        fmt::format(".upper = {}", number(m->jnt_range[2 * j + 1])),
                        fmt::format(".margin = {}", number(m->jnt_margin[j])),
                        softness(m->jnt_solref + mjNREF * j, m->jnt_solimp + mjNIMP * j),
                        fmt::format(".inverse_weight = {}",
                                    number(m->dof_invweight0[m->jnt_dofadr[j]]))});
    }
    entries("eom::JointLimit", "joint_limits", limits);
    for (int v = 0; v < m->nv; ++v)
      if (m->dof_frictionloss[v] > 0)
        losses.push_back({fmt::format(".velocity = {}", v),
                          fmt::format(".loss = {}", number(m->dof_frictionloss[v])),
                          softness(m->dof_solref + mjNREF * v, m->dof_solimp + mjNIMP * v),
                          fmt::format(".inverse_weight = {}", number(m->dof_invweight0[v]))});
    entries("eom::FrictionLoss", "friction_losses", losses);
    entries("eom::EqualitySoftness", "equality_softness", equality_softness);
    {  // every fixed tendon, in MuJoCo's order (its id), for its limit's and friction loss's rows
      int most = 1;
      for (int t = 0; t < m->ntendon; ++t) most = std::max(most, m->tendon_num[t]);
      std::vector<std::vector<std::string>> tendons;
      for (int t = 0; t < m->ntendon; ++t) {
        std::vector<std::string> f, joints;
        const char* n = mj_id2name(m, mjOBJ_TENDON, t);
        if (n && *n) f.push_back(".name = " + gen::detail::string_literal(n));
        f.push_back(fmt::format(".count = {}", m->tendon_num[t]));
        for (int w = m->tendon_adr[t]; w < m->tendon_adr[t] + m->tendon_num[t]; ++w) {
          const int j = m->wrap_objid[w];
          joints.push_back(fmt::format("{{{}, {}, {}}}", m->jnt_qposadr[j], m->jnt_dofadr[j], number(m->wrap_prm[w])));
        }
        f.push_back(fmt::format(".joints = {{{{{}}}}}", fmt::join(joints, ", ")));
        if (m->tendon_limited[t]) {
          f.push_back(".limited = true");
          f.push_back(fmt::format(".lower = {}", number(m->tendon_range[2 * t])));
          f.push_back(fmt::format(".upper = {}", number(m->tendon_range[2 * t + 1])));
          f.push_back(fmt::format(".margin = {}", number(m->tendon_margin[t])));
          f.push_back(softness(m->tendon_solref_lim + mjNREF * t, m->tendon_solimp_lim + mjNIMP * t));
        }
        if (m->tendon_frictionloss[t] > 0) {
          f.push_back(fmt::format(".frictionloss = {}", number(m->tendon_frictionloss[t])));
          f.push_back(softness(m->tendon_solref_fri + mjNREF * t, m->tendon_solimp_fri + mjNIMP * t,
                               "friction_softness"));
        }
        f.push_back(fmt::format(".inverse_weight = {}", number(m->tendon_invweight0[t])));
        tendons.push_back(f);
      }
      entries(fmt::format("eom::FixedTendon<{}>", most), "tendons", tendons);
    }
    {  // per velocity, for the semi-implicit Euler step (its damping taken implicitly, as MuJoCo)
      std::vector<std::string> damping;
      for (int v = 0; v < m->nv; ++v) damping.push_back(number(m->dof_damping[v]));
      line(gen::detail::wrap(fmt::format("  static constexpr std::array<double, {}> damping{{", m->nv),
                             damping, "};"));
    }
    {
      std::vector<std::string> q;
      for (int i = 0; i < m->nq; ++i) q.push_back(number(m->qpos0[i]));
      line("  // MuJoCo's qpos0, where mj_resetData starts: the bodies as the file places them (a free");
      line("  // joint at its body's placement, a ball joint unturned, a hinge or slide at its ref).");
      line(gen::detail::wrap(fmt::format("  static constexpr std::array<double, {}> qpos0{{", m->nq), q, "};"));
    }

    const mjOption& o = m->opt;
    eom::SolverOptions options{.timestep = o.timestep, .impratio = o.impratio,
                               .tolerance = o.tolerance, .iterations = o.iterations,
                               .noslip_iterations = o.noslip_iterations,
                               .noslip_tolerance = o.noslip_tolerance, .integrator = o.integrator,
                               .cone = o.cone, .solver = o.solver, .disable_flags = o.disableflags,
                               .enable_flags = o.enableflags, .override_margin = o.o_margin,
                               .override_softness = {}};
    std::copy_n(o.o_solref, mjNREF, options.override_softness.solref.begin());
    std::copy_n(o.o_solimp, mjNIMP, options.override_softness.solimp.begin());
    line(gen::detail::solver_options_text(options, number));

    std::vector<std::vector<std::string>> keys;
    for (int k = 0; k < m->nkey; ++k) {
      std::vector<std::string> f;
      const char* n = mj_id2name(m, mjOBJ_KEY, k);
      if (n && *n) f.push_back(".name = " + gen::detail::string_literal(n));
      f.push_back(fmt::format(".time = {}", number(m->key_time[k])));
      f.push_back(".qpos = " + numbers(m->key_qpos + m->nq * k, m->nq));
      f.push_back(".qvel = " + numbers(m->key_qvel + m->nv * k, m->nv));
      if (m->nu > 0) f.push_back(".ctrl = " + numbers(m->key_ctrl + m->nu * k, m->nu));
      keys.push_back(f);
    }
    entries(fmt::format("eom::Keyframe<{}, {}, {}>", m->nq, m->nv, m->nu), "keyframes", keys);
  }
  line("");
  line("  template <class S>");
  line("  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {");
  line("    std::array<eom::TreeLink<S>, link_count> l;");
  line("    tree<S>(p, l);");
  line(rotors.empty() ? "    eom::tree_bodies<S>(l, q, b);"
                      : "    eom::tree_bodies<S>(l, q, b.first(link_count));");
  if (!rotors.empty()) {
    line(
        "    // A joint's armature, as MuJoCo's: a rotor turned by the joint's coordinate alone (T "
        "= armature");
    line("    // qd^2 / 2; no mass, so no weight), the Lagrangian twin of TreeLink::armature.");
    for (std::size_t r = 0; r < rotors.size(); ++r) {
      const std::string a = number(rotors[r].second), half = number(rotors[r].second / 2);
      line(
          fmt::format("    b[link_count + {}] = eom::rigid_body<S>(eom::revolute<S>({{0.0, 0.0, "
                      "1.0}}, q[{}]), S(0),",
                      r, rotors[r].first));
      line(fmt::format(
          "                                       {{S({}), S({}), S({}), S(0), S(0), S(0)}});",
          half, half, a));
    }
  }
  line("  }");
  line("");
  line("  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {");
  line("    std::array<eom::TreeLink<S>, link_count> l;");
  line("    tree<S>(p, l);");
  line("    std::array<eom::SpatialBody<S>, link_count> b;");
  line("    eom::tree_bodies<S>(l, q, b);");
  if (vertical) {
    line("    return eom::gravity_potential<S>(b, p[0]);");
  } else {
    line("    S v(0);  // -sum m (gravity . x)");
    line("    for (const auto& x : b)");
    line(
        "      v = v - x.mass * (p[0] * x.position[0] + p[1] * x.position[1] + p[2] * "
        "x.position[2]);");
    line("    return v;");
  }
  line("  }");
  line("");
  std::string body;
  for (const std::string& s : force_lines) body += s + "\n";
  const bool uses_q = body.find("q[") != std::string::npos,
             uses_qd = body.find("qd[") != std::string::npos;
  const bool uses_u = body.find("u[") != std::string::npos;
  line("  template <class S>");
  line(fmt::format(
      "  static void generalized_forces(const S&, eom::In<S>{}, eom::In<S>{}, eom::In<S>{}, "
      "eom::In<S>, eom::Out<S> Q) {{",
      uses_q ? " q" : "", uses_qd ? " qd" : "", uses_u ? " u" : ""));
  line("    for (S& x : Q) x = S(0);");
  out.append(body);
  line("  }");
  line("};");
  line("");
  line(fmt::format("}}  // namespace {}", options.ns));
  return fmt::to_string(out);
}

}  // namespace eom::mjcf
