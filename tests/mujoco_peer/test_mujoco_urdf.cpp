// The bundled fixed-base URDF robots (models/robots: panda.urdf, ur5.urdf, branched.urdf) read by
// MuJoCo's own URDF importer (mj_loadXML) and compared with the kernels eomgen generated from the
// same files: an independent reader of the file (origins, rpy, axes, inertial frames, the fixed
// joints, the prismatic joint) and an independent implementation of the dynamics. MuJoCo's
// constraints are off (mjDSBL_CONSTRAINT: limits and friction loss belong to its solver). At
// random states: M against mj_fullM, forward dynamics against qacc after mj_forward, inverse
// dynamics against mj_inverse's qfrc_inverse, every frame against xpos/xmat of the body of the
// same name; the joint ranges, damping, masses and mass centres as data. Every difference is
// max |a − b| / max |b| (b MuJoCo's), as in tests/mjcf; the worst are printed.
//
// What MuJoCo's URDF import needs, and what is changed on the way in:
// - fusestatic="false" (MuJoCo's URDF extension, <mujoco><compiler .../></mujoco>, added to the
//   file's text in memory): by default MuJoCo fuses the bodies without joints into their parents,
//   which leaves the dynamics alone but removes the names of the links on fixed joints (the
//   roots, flange, tool0, panda_link8, the sensor plate), so their frames could not be compared.
// - The massless link between two joints (branched.urdf's right_yoke): eomgen takes it (the child's
//   mass keeps M regular), MuJoCo's compiler refuses it ("mass and inertia of moving bodies must be
//   larger than mjMINVAL"). boundmass="1e-14" boundinertia="1e-14" (branched.urdf only) lets it
//   compile; after compiling, the test sets the mass and inertia of every body whose link has no
//   <inertial> back to 0, as in the file (MuJoCo's dynamics take a massless body; the bound left
//   in moved v̇ by 5e-12, through the small moments of the arm behind the yoke).
// - No meshes: the bundled files have no <visual> or <collision> (models/robots/README.md), so
//   MuJoCo loads no geometry and its inertias are the files' <inertial>s alone.
// - Inputs: MuJoCo builds no actuators from a URDF file (nu = 0), eomgen gives every moving joint
//   an input u (Q = u − d⊙q̇): u goes into MuJoCo as qfrc_applied, at the joint of the same name.
//   <dynamics damping> is MuJoCo's joint damping (checked equal, as data); <dynamics friction>
//   would be MuJoCo's frictionloss, a constraint that mjDSBL_CONSTRAINT drops while eomgen
//   smooths it into Q: none of the three files has friction (checked), so nothing differs. No
//   armature (checked zero in MuJoCo) and no mimic joints in these files.
// - Inertias: MuJoCo stores a body's inertia as principal moments (body_inertia) and axes
//   (body_iquat), and its compiler's Jacobi iteration (mjuu_eig3) stops once the next rotation
//   would turn by less than about 1.4e-6 rad (cosine > 1 − 1e-12), dropping what is left off the
//   diagonal: the Panda's compiled tensors are off the file's by up to 6.5e-7 of the largest
//   moment, the branched robot's by 1.2e-8 (nearly diagonal tensors), the UR5's by rounding
//   (diagonal in the file), and M, v̇, τ follow (printed: up to 4e-7 for the Panda's v̇). That is
//   MuJoCo's rounding of the data, not a difference in the dynamics, so the comparison takes it
//   out: the test reads each <inertial> itself (tinyxml2), turns the tensor into the link frame
//   (the inertial origin's rpy, R = Rz Ry Rx), decomposes it to rounding (cyclic Jacobi to
//   convergence) and writes body_inertia and body_iquat; the dynamics are then held to 1e-12.
//   MuJoCo's own reading stays checked, as data: mass and mass centre equal to the file's, and
//   the compiled tensor within its Jacobi's stop of the file's (each dropped entry below about
//   1.4e-6 times a difference of two moments; held to 4e-6 · (largest − smallest moment)).
// - Joint order: eomgen's coordinates are the moving joints in file order, MuJoCo's its depth-first
//   body order; they are matched by name.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "mujoco_peer.hpp"
#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <branched_robot.hpp>
#include <panda.hpp>
#include <panda_frames.hpp>
#include <peer_branched_frames.hpp>
#include <peer_ur5_frames.hpp>
#include <ur5.hpp>

namespace {

using eom::test::relative;
using Model = eom::test::MujocoModel;
using Data = eom::test::MujocoData;

std::string read_text(const std::string& file) {
  std::ifstream in(file);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// The URDF file with `compiler` (attributes of MuJoCo's <compiler>) added as MuJoCo's URDF
// extension, loaded by mj_loadXML from memory (a virtual file of the same name).
Model load_urdf(const std::string& file, const std::string& compiler) {
  std::string text = read_text(file);
  const std::size_t end = text.rfind("</robot>");
  EXPECT_NE(end, std::string::npos) << file;
  if (end == std::string::npos) return nullptr;
  text.insert(end, "<mujoco><compiler " + compiler + "/></mujoco>\n");
  const std::string name = file.substr(file.find_last_of('/') + 1);
  char error[1000] = "";
  Model model = eom::test::load_text(name.c_str(), text, error, sizeof error);
  EXPECT_TRUE(model) << file << ": " << error;
  return model;
}

// 3×3 matrices row-major.
void multiply(const double* A, const double* B, double* C, bool transpose_b = false) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double sum = 0;
      for (int k = 0; k < 3; ++k) sum += A[3 * i + k] * (transpose_b ? B[3 * j + k] : B[3 * k + j]);
      C[3 * i + j] = sum;
    }
}

// A symmetric = V diag(w) Vᵀ, V a rotation: cyclic Jacobi until nothing is left off the diagonal
// but rounding (quadratic convergence: a few sweeps).
void eigen_decomposition(const double* A_in, double* w, double* V) {
  double A[9], J[9], T[9];
  std::copy(A_in, A_in + 9, A);
  const double I3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::copy(I3, I3 + 9, V);
  const double scale = std::abs(A[0]) + std::abs(A[4]) + std::abs(A[8]);
  for (int sweep = 0; sweep < 50; ++sweep) {
    if (std::abs(A[1]) + std::abs(A[2]) + std::abs(A[5]) <= 1e-20 * scale) break;
    for (const auto& [p, q] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}}) {
      const double apq = A[3 * p + q];
      if (apq == 0) continue;
      const double theta = (A[3 * q + q] - A[3 * p + p]) / (2 * apq);
      const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
      const double c = 1 / std::sqrt(t * t + 1), s = t * c;
      std::copy(I3, I3 + 9, J);
      J[3 * p + p] = c, J[3 * q + q] = c, J[3 * p + q] = s, J[3 * q + p] = -s;
      multiply(A, J, T);  // A ← Jᵀ A J
      double Jt[9];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Jt[3 * i + j] = J[3 * j + i];
      multiply(Jt, T, A);
      A[3 * p + q] = A[3 * q + p] = 0;
      multiply(V, J, T);
      std::copy(T, T + 9, V);
    }
  }
  for (int i = 0; i < 3; ++i) w[i] = A[4 * i];
  const double det = V[0] * (V[4] * V[8] - V[5] * V[7]) - V[1] * (V[3] * V[8] - V[5] * V[6]) +
                     V[2] * (V[3] * V[7] - V[4] * V[6]);
  if (det < 0)
    for (int i = 0; i < 3; ++i) V[3 * i + 2] = -V[3 * i + 2];
}

// A link's <inertial> as the file writes it; the tensor in the link frame (R I Rᵀ, R = Rz Ry Rx
// of the inertial origin's rpy).
struct Inertial {
  std::string link;
  double mass = 0;
  double xyz[3] = {0, 0, 0};
  double tensor[9] = {};
};

std::vector<Inertial> read_inertials(const std::string& file) {
  tinyxml2::XMLDocument doc;
  EXPECT_EQ(doc.LoadFile(file.c_str()), tinyxml2::XML_SUCCESS) << file;
  std::vector<Inertial> out;
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) return out;
  for (const auto* link = robot->FirstChildElement("link"); link;
       link = link->NextSiblingElement("link")) {
    const auto* inertial = link->FirstChildElement("inertial");
    if (!inertial) continue;
    Inertial in;
    in.link = link->Attribute("name");
    in.mass = inertial->FirstChildElement("mass")->DoubleAttribute("value");
    double rpy[3] = {0, 0, 0};
    if (const auto* origin = inertial->FirstChildElement("origin")) {
      std::istringstream(origin->Attribute("xyz") ? origin->Attribute("xyz") : "0 0 0") >>
          in.xyz[0] >> in.xyz[1] >> in.xyz[2];
      std::istringstream(origin->Attribute("rpy") ? origin->Attribute("rpy") : "0 0 0") >> rpy[0] >>
          rpy[1] >> rpy[2];
    }
    const auto* e = inertial->FirstChildElement("inertia");
    const double xx = e->DoubleAttribute("ixx"), yy = e->DoubleAttribute("iyy"),
                 zz = e->DoubleAttribute("izz"), xy = e->DoubleAttribute("ixy"),
                 xz = e->DoubleAttribute("ixz"), yz = e->DoubleAttribute("iyz");
    const double I[9] = {xx, xy, xz, xy, yy, yz, xz, yz, zz};
    const double cr = std::cos(rpy[0]), sr = std::sin(rpy[0]), cp = std::cos(rpy[1]),
                 sp = std::sin(rpy[1]), cy = std::cos(rpy[2]), sy = std::sin(rpy[2]);
    const double Rz[9] = {cy, -sy, 0, sy, cy, 0, 0, 0, 1}, Ry[9] = {cp, 0, sp, 0, 1, 0, -sp, 0, cp},
                 Rx[9] = {1, 0, 0, 0, cr, -sr, 0, sr, cr};
    double R[9], T[9];
    multiply(Rz, Ry, T);
    multiply(T, Rx, R);
    multiply(R, I, T);
    multiply(T, R, in.tensor, true);
    out.push_back(in);
  }
  return out;
}

// MuJoCo's inertia of body b as a tensor in the body frame: R diag(body_inertia) Rᵀ.
void mujoco_tensor(const mjModel* m, int b, double* tensor) {
  double R[9], T[9];
  mju_quat2Mat(R, m->body_iquat + 4 * b);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) T[3 * i + j] = R[3 * i + j] * m->body_inertia[3 * b + j];
  multiply(T, R, tensor, true);
}

// Checks MuJoCo's reading of the inertials (mass and mass centre exactly; the tensor to its
// Jacobi's stop, see the top) and, if `exact`, replaces its principal moments and axes by a
// decomposition of the file's tensor to rounding and makes the links without <inertial> massless
// again (boundmass). Returns the worst tensor difference of MuJoCo's compilation, relative to the
// largest moment.
double inertias(mjModel* m, const std::string& file, bool exact) {
  double worst = 0;
  const std::vector<Inertial> file_inertials = read_inertials(file);
  if (exact)
    for (int b = 1; b < m->nbody; ++b) {
      const char* body = mj_id2name(m, mjOBJ_BODY, b);
      if (body && std::none_of(file_inertials.begin(), file_inertials.end(),
                               [&](const Inertial& in) { return in.link == body; })) {
        m->body_mass[b] = 0;
        std::fill(m->body_inertia + 3 * b, m->body_inertia + 3 * b + 3, 0.0);
      }
    }
  for (const Inertial& in : file_inertials) {
    const int b = mj_name2id(m, mjOBJ_BODY, in.link.c_str());
    EXPECT_GE(b, 0) << in.link;
    if (b < 0) continue;
    EXPECT_EQ(m->body_mass[b], in.mass) << in.link;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(m->body_ipos[3 * b + i], in.xyz[i]) << in.link;
    double w[3], V[9], compiled[9];
    eigen_decomposition(in.tensor, w, V);
    mujoco_tensor(m, b, compiled);
    double diff = 0;
    for (int i = 0; i < 9; ++i) diff = std::max(diff, std::abs(compiled[i] - in.tensor[i]));
    const double largest = std::max({w[0], w[1], w[2]}), smallest = std::min({w[0], w[1], w[2]});
    EXPECT_LE(diff, 4e-6 * (largest - smallest) + 1e-15 * largest) << in.link;
    worst = std::max(worst, diff / largest);
    if (exact) {
      double quat[4];
      mju_mat2Quat(quat, V);
      mju_normalize4(quat);
      std::copy(quat, quat + 4, m->body_iquat + 4 * b);
      std::copy(w, w + 3, m->body_inertia + 3 * b);
      mujoco_tensor(m, b, compiled);
      EXPECT_LE(relative(compiled, in.tensor, 9), 4e-15) << in.link;
    }
  }
  return worst;
}

struct Worst {
  double mass = 0, forward = 0, inverse = 0, frames = 0;
};

// K: the dynamics (mass_matrix, forward_dynamics, inverse_dynamics); F: the frame placements, of
// the same file. exact: MuJoCo's inertias decomposed to rounding (see the top), else as compiled.
template <class K, class F>
Worst compare(const char* name, const std::string& compiler, bool exact, int samples) {
  const std::string file = std::string(EOM_ROBOTS_DIR) + "/" + name;
  const Model model = load_urdf(file, compiler);
  if (!model) return {};
  mjModel* m = model.get();
  m->opt.disableflags |= mjDSBL_CONSTRAINT;
  const double compiled_inertia = inertias(m, file, exact);
  const Data data(mj_makeData(m));
  mjData* d = data.get();
  constexpr int n = K::nv;
  static_assert(K::nq == n && F::nq == n, "a fixed base");
  EXPECT_EQ(m->nq, n);
  EXPECT_EQ(m->nv, n);
  EXPECT_EQ(m->nu, 0);  // inputs as qfrc_applied
  EXPECT_EQ(K::nu, n);
  if (m->nq != n || m->nv != n) return {};

  // Coordinate i is MuJoCo's dof at[i] (hinges and slides: qpos and qvel addresses alike).
  std::vector<int> at(n);
  for (int i = 0; i < n; ++i) {
    const std::string joint(K::coordinate_names[i]);
    const int j = mj_name2id(m, mjOBJ_JOINT, joint.c_str());
    EXPECT_GE(j, 0) << joint;
    if (j < 0) return {};
    EXPECT_TRUE(m->jnt_type[j] == mjJNT_HINGE || m->jnt_type[j] == mjJNT_SLIDE) << joint;
    EXPECT_EQ(m->jnt_qposadr[j], m->jnt_dofadr[j]) << joint;
    at[i] = m->jnt_dofadr[j];
    // The data both read: the range, the damping; no friction, no armature.
    EXPECT_EQ(K::position_lower[i], m->jnt_range[2 * j]) << joint;
    EXPECT_EQ(K::position_upper[i], m->jnt_range[2 * j + 1]) << joint;
    double damping = 0;
    for (int k = 0; k < K::np; ++k) {
      EXPECT_NE(K::parameter_names[k], joint + "_friction");
      if (K::parameter_names[k] == joint + "_damping") damping = K::parameter_values[k];
    }
    EXPECT_EQ(m->dof_damping[at[i]], damping) << joint;
    EXPECT_EQ(m->dof_frictionloss[at[i]], 0.0) << joint;
    EXPECT_EQ(m->dof_armature[at[i]], 0.0) << joint;
  }
  // Every frame is a MuJoCo body of the same name (fusestatic off).
  std::vector<int> body(F::nframes);
  for (int f = 0; f < F::nframes; ++f) {
    body[f] = mj_name2id(m, mjOBJ_BODY, std::string(F::frame_names[f]).c_str());
    EXPECT_GE(body[f], 0) << F::frame_names[f];
    if (body[f] < 0) return {};
  }

  const double* p = K::parameter_values.data();
  const double* pf = F::parameter_values.data();
  std::mt19937_64 rng(47);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Worst worst;
  std::vector<double> q(n), v(n), u(n), a(n), qdd(n), tau(n), expected(n), mujoco(n), M(n * n),
      M_mujoco(n * n), M_ours(n * n);
  for (int sample = 0; sample < samples; ++sample) {
    // Angles in [−3.14, 3.14], the slide in [−0.1, 0.1] m (its range), rates, forces.
    for (int i = 0; i < n; ++i) {
      const int j = m->dof_jntid[at[i]];
      q[i] = (m->jnt_type[j] == mjJNT_SLIDE ? 0.1 : 3.14) * unit(rng);
      v[i] = 2 * unit(rng), a[i] = 3 * unit(rng), u[i] = 10 * unit(rng);
    }
    for (int i = 0; i < n; ++i) {
      d->qpos[at[i]] = q[i];
      d->qvel[at[i]] = v[i];
      d->qfrc_applied[at[i]] = u[i];
    }
    mj_forward(m, d);

    K::mass_matrix(q.data(), p, M.data());
    mj_fullM(m, M_mujoco.data(), d->qM);  // symmetric: row- and column-major alike
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < n; ++k) M_ours[i + n * k] = M_mujoco[at[i] + n * at[k]];
    worst.mass = std::max(worst.mass, relative(M.data(), M_ours.data(), n * n));

    EXPECT_TRUE(K::forward_dynamics(0.0, q.data(), v.data(), u.data(), p, qdd.data()));
    for (int i = 0; i < n; ++i) mujoco[i] = d->qacc[at[i]];
    worst.forward = std::max(worst.forward, relative(qdd.data(), mujoco.data(), n));

    for (int f = 0; f < F::nframes; ++f) {
      double x[3], R[9], Rt[9];
      F::frame_placement(f, q.data(), pf, x, R);
      const double* xm = d->xmat + 9 * body[f];
      for (int i = 0; i < 3; ++i)  // MuJoCo's row-major xmat, column-major
        for (int k = 0; k < 3; ++k) Rt[i + 3 * k] = xm[3 * i + k];
      worst.frames =
          std::max({worst.frames, relative(x, d->xpos + 3 * body[f], 3), relative(R, Rt, 9)});
    }

    // MuJoCo's qfrc_inverse = M a + bias − passive (applied forces not subtracted); eomgen's
    // τ = M a + c + ∂V/∂q − Q with Q = u − d⊙v: τ = qfrc_inverse − u.
    for (int i = 0; i < n; ++i) d->qacc[at[i]] = a[i];
    mj_inverse(m, d);
    for (int i = 0; i < n; ++i) expected[i] = d->qfrc_inverse[at[i]] - u[i];
    K::inverse_dynamics(0.0, q.data(), v.data(), a.data(), u.data(), p, tau.data());
    worst.inverse = std::max(worst.inverse, relative(tau.data(), expected.data(), n));
  }
  std::printf(
      "%s, MuJoCo's inertias %s (its compiled tensors off the file's by %.2e): worst relative "
      "difference over %d states: M %.2e, forward dynamics %.2e, inverse dynamics %.2e, frames "
      "(%d) %.2e\n",
      name, exact ? "decomposed to rounding" : "as compiled", compiled_inertia, samples, worst.mass,
      worst.forward, worst.inverse, F::nframes, worst.frames);
  return worst;
}

void expect_agreement(const Worst& w) {
  EXPECT_LE(w.mass, 1e-12);
  EXPECT_LE(w.forward, 1e-12);
  EXPECT_LE(w.inverse, 1e-12);
  EXPECT_LE(w.frames, 1e-12);
}

// Compared twice: with MuJoCo's inertias as compiled (printed: the size of its rounding; only
// the frames, which inertias do not touch, are held to 1e-12) and decomposed to rounding.
template <class K, class F>
void expect_agreement(const char* file, const std::string& compiler) {
  const Worst compiled = compare<K, F>(file, compiler, false, 200);
  EXPECT_LE(compiled.frames, 1e-12);
  expect_agreement(compare<K, F>(file, compiler, true, 200));
}

const std::string keep_links = "fusestatic=\"false\"";

// The Panda's frames: tests/frames' panda_frames (the flange panda_link8, the root panda_link0,
// panda_link4).
TEST(mujoco_urdf, PandaAgreesWithMuJoCo) {
  expect_agreement<panda::Kernels, panda_frames::Kernels>("panda.urdf", keep_links);
}
TEST(mujoco_urdf, Ur5AgreesWithMuJoCo) {
  expect_agreement<ur5::Kernels, peer_ur5_frames::Kernels>("ur5.urdf", keep_links);
}
TEST(mujoco_urdf, BranchedAgreesWithMuJoCo) {
  expect_agreement<branched_robot::Kernels, peer_branched_frames::Kernels>(
      "branched.urdf", keep_links + " boundmass=\"1e-14\" boundinertia=\"1e-14\"");
}

}  // namespace
