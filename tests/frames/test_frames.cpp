// Task space (eom/multibody/frames.hpp): every generated frame and mass-centre kernel against eom::Reference
// (AD, the oracle) for the three ways a model gives frames — frames() in the body form (fixed
// base, and on the free joint), link_frames in the tree form (floating, with a frame on the
// world), and URDF links (the Panda's massless flange through a fixed joint; Solo12 flying) —;
// the reference itself against central differences in dd_real (Jacobians of placements, biases
// of J v along the motion) and the mass centre against Σ mᵢ xᵢ / Σ mᵢ; bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <frame_arm.hpp>
#include <free_body_frames.hpp>
#include <free_tree_frames.hpp>
#include <panda_frames.hpp>
#include <panda_frames_model.hpp>
#include <solo12_frames.hpp>
#include <solo12_frames_model.hpp>

#include <qd/dd_real.h>

#include <eom/model/free_joint.hpp>
#include <eom/model/kernels.hpp>
#include <eom/multibody/frames.hpp>
#include <eom/reference/reference.hpp>
#include <eomgen/tracer.hpp>

#include "frame_models.hpp"
#include "kernel_error.hpp"
#include "recursive_dynamics.hpp"

namespace {

using eomtest::kernel_error;

// Frame f of K (FRAMES' order) is frame reference_index(f) of the model.
template <class K, class R> int reference_index(int f) {
  const auto at = std::find(R::frame_names.begin(), R::frame_names.end(), K::frame_names[f]);
  return static_cast<int>(at - R::frame_names.begin());
}

template <class R> void random_state(std::mt19937_64& rng, std::vector<double>& q, std::vector<double>& v) {
  std::uniform_real_distribution<double> x(-1, 1);
  q.resize(R::nq);
  v.resize(R::nv);
  for (double& e : q) e = 1.5 * x(rng);
  for (double& e : v) e = 2 * x(rng);
  eom::normalize_configuration(eom::Layout(R::nq, R::nv), q.data());
}

// Every task-space kernel of K against the reference's at `trials` random states.
template <class K, class Model> void compare_with_reference(const char* name, int trials) {
  using R = eom::Reference<Model>;
  constexpr int nv = K::nv;
  static_assert(K::nq == R::nq && nv == R::nv && K::np == R::np);
  std::mt19937_64 rng(7);
  const auto& p = K::parameter_values;
  double worst[6] = {};
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<double> q, v;
    random_state<R>(rng, q, v);
    std::vector<double> g(6 * nv), r(6 * nv), g2(9), r2(9);
    for (int f = 0; f < K::nframes; ++f) {
      const int fr = reference_index<K, R>(f);
      ASSERT_LT(fr, R::nframes) << K::frame_names[f];
      K::frame_placement(f, q.data(), p.data(), g.data(), g2.data());
      R::frame_placement(fr, q.data(), p.data(), r.data(), r2.data());
      worst[0] = std::max({worst[0], kernel_error(g.data(), r.data(), 3), kernel_error(g2.data(), r2.data(), 9)});
      K::frame_jacobian(f, q.data(), p.data(), g.data());
      R::frame_jacobian(fr, q.data(), p.data(), r.data());
      worst[1] = std::max(worst[1], kernel_error(g.data(), r.data(), 6 * nv));
      K::frame_acceleration_bias(f, q.data(), v.data(), p.data(), g.data());
      R::frame_acceleration_bias(fr, q.data(), v.data(), p.data(), r.data());
      worst[2] = std::max(worst[2], kernel_error(g.data(), r.data(), 6));
    }
    K::center_of_mass(q.data(), p.data(), g.data());
    R::center_of_mass(q.data(), p.data(), r.data());
    worst[3] = std::max(worst[3], kernel_error(g.data(), r.data(), 3));
    K::center_of_mass_jacobian(q.data(), p.data(), g.data());
    R::center_of_mass_jacobian(q.data(), p.data(), r.data());
    worst[4] = std::max(worst[4], kernel_error(g.data(), r.data(), 3 * nv));
    K::centroidal_momentum_matrix(q.data(), p.data(), g.data());
    R::centroidal_momentum_matrix(q.data(), p.data(), r.data());
    worst[5] = std::max(worst[5], kernel_error(g.data(), r.data(), 6 * nv));
  }
  const char* kernels[] = {"frame_placement", "frame_jacobian", "frame_acceleration_bias",
                           "center_of_mass", "center_of_mass_jacobian", "centroidal_momentum_matrix"};
  for (int k = 0; k < 6; ++k) {
    std::printf("%-18s %-28s worst %.2e\n", name, kernels[k], worst[k]);
    EXPECT_LT(worst[k], 1e-12) << name << ": " << kernels[k];
  }
}

TEST(GeneratedFrames, FramesOfTheBodyFormMatchTheReference) {
  compare_with_reference<frame_arm::Kernels, frames_test::FrameArm>("frame_arm", 40);
}
TEST(GeneratedFrames, FramesOnTheFreeJointMatchTheReference) {
  compare_with_reference<free_body_frames::Kernels, frames_test::FreeBodyFrames>("free_body_frames", 40);
}
TEST(GeneratedFrames, FramesOnTheTreeMatchTheReference) {
  compare_with_reference<free_tree_frames::Kernels, frames_test::FreeTreeFrames>("free_tree_frames", 40);
}
TEST(GeneratedFrames, UrdfLinksMatchTheReference) {
  compare_with_reference<panda_frames::Kernels, eom::urdf_models::panda_frames>("panda_frames", 20);
  compare_with_reference<solo12_frames::Kernels, eom::urdf_models::solo12_frames>("solo12_frames", 20);
}

// The frames' names and order are FRAMES'; the kernels fill NaN for an index out of range.
TEST(GeneratedFrames, IndicesFollowFramesAndOutOfRangeIsNaN) {
  using K = free_tree_frames::Kernels;
  static_assert(K::nframes == 4);
  EXPECT_EQ(K::frame_names[0], "world_mark");
  EXPECT_EQ(K::frame_names[3], "base");
  std::vector<double> q, v;
  std::mt19937_64 rng(1);
  random_state<K>(rng, q, v);
  for (int f : {-1, 4, 1000}) {
    std::array<double, 6 * K::nv> J;
    std::array<double, 9> rotation;
    std::array<double, 3> position;
    std::array<double, 6> a;
    J.fill(0.0);
    K::frame_jacobian(f, q.data(), K::parameter_values.data(), J.data());
    K::frame_placement(f, q.data(), K::parameter_values.data(), position.data(), rotation.data());
    K::frame_acceleration_bias(f, q.data(), v.data(), K::parameter_values.data(), a.data());
    for (double x : J) EXPECT_TRUE(std::isnan(x));
    for (double x : position) EXPECT_TRUE(std::isnan(x));
    for (double x : rotation) EXPECT_TRUE(std::isnan(x));
    for (double x : a) EXPECT_TRUE(std::isnan(x));
    using R = eom::Reference<frames_test::FreeTreeFrames>;
    R::frame_jacobian(f, q.data(), K::parameter_values.data(), J.data());
    for (double x : J) EXPECT_TRUE(std::isnan(x));
  }
  // A frame on the world stays where it is.
  std::array<double, 6 * K::nv> J;
  std::array<double, 6> a;
  K::frame_jacobian(0, q.data(), K::parameter_values.data(), J.data());
  K::frame_acceleration_bias(0, q.data(), v.data(), K::parameter_values.data(), a.data());
  for (double x : J) EXPECT_EQ(x, 0.0);
  for (double x : a) EXPECT_EQ(x, 0.0);
}

// The Panda's flange, massless and behind a fixed joint, is kept: 0.107 m along link 7's z axis.
TEST(GeneratedFrames, TheFlangeSitsOnLinkSeven) {
  using K = panda_frames::Kernels;
  using R = eom::Reference<eom::urdf_models::panda_frames>;
  ASSERT_EQ(K::frame_names[0], "panda_link8");
  const int link7 = static_cast<int>(std::find(R::frame_names.begin(), R::frame_names.end(), "panda_link7") -
                                     R::frame_names.begin());
  ASSERT_LT(link7, R::nframes);
  std::vector<double> q, v;
  std::mt19937_64 rng(3);
  random_state<R>(rng, q, v);
  std::array<double, 3> x8, x7;
  std::array<double, 9> r8, r7;
  K::frame_placement(0, q.data(), K::parameter_values.data(), x8.data(), r8.data());
  R::frame_placement(link7, q.data(), K::parameter_values.data(), x7.data(), r7.data());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(x8[k], x7[k] + 0.107 * r7[6 + k], 1e-15);
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(r8[k], r7[k], 1e-15);
}

// The URDF robots' generated kernels against the independent recursive implementation in dd_real
// (tests/support/recursive_dynamics.hpp: its own spatial algebra, read straight from the file).
template <class K> void compare_with_recursive(const char* name, const char* file, bool floating) {
  constexpr int nv = K::nv;
  const auto robot = eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/" + file, floating);
  eomtest::RecursiveDynamics<dd_real> rd(robot);
  std::mt19937_64 rng(13);
  double worst[6] = {};
  auto error = [](const std::vector<double>& g, const std::vector<dd_real>& r) {
    std::vector<double> rr;
    for (const dd_real& x : r) rr.push_back(to_double(x));
    return kernel_error(g.data(), rr.data(), static_cast<int>(g.size()));
  };
  for (int trial = 0; trial < 10; ++trial) {
    std::vector<double> q, v;
    random_state<K>(rng, q, v);
    std::vector<dd_real> Q(q.begin(), q.end()), V(v.begin(), v.end());
    const auto& p = K::parameter_values;
    for (int f = 0; f < K::nframes; ++f) {
      const std::string link(K::frame_names[f]);
      std::vector<double> x(3), R(9), J(6 * nv), a(6);
      std::vector<dd_real> xr(3), Rr(9), Jr(6 * nv), ar(6);
      K::frame_placement(f, q.data(), p.data(), x.data(), R.data());
      K::frame_jacobian(f, q.data(), p.data(), J.data());
      K::frame_acceleration_bias(f, q.data(), v.data(), p.data(), a.data());
      rd.frame_placement(link, Q.data(), xr.data(), Rr.data());
      rd.frame_jacobian(link, Q.data(), Jr.data());
      rd.frame_acceleration_bias(link, Q.data(), V.data(), ar.data());
      worst[0] = std::max({worst[0], error(x, xr), error(R, Rr)});
      worst[1] = std::max(worst[1], error(J, Jr));
      worst[2] = std::max(worst[2], error(a, ar));
    }
    std::vector<double> c(3), Jc(3 * nv), A(6 * nv);
    std::vector<dd_real> cr(3), Jcr(3 * nv), Ar(6 * nv);
    K::center_of_mass(q.data(), p.data(), c.data());
    K::center_of_mass_jacobian(q.data(), p.data(), Jc.data());
    K::centroidal_momentum_matrix(q.data(), p.data(), A.data());
    rd.center_of_mass(Q.data(), cr.data());
    rd.center_of_mass_jacobian(Q.data(), Jcr.data());
    rd.centroidal_momentum_matrix(Q.data(), Ar.data());
    worst[3] = std::max(worst[3], error(c, cr));
    worst[4] = std::max(worst[4], error(Jc, Jcr));
    worst[5] = std::max(worst[5], error(A, Ar));
  }
  std::printf("%-14s against the recursive implementation (dd_real): placement %.1e, J %.1e, "
              "J̇v %.1e, mass centre %.1e, its J %.1e, A_G %.1e\n",
              name, worst[0], worst[1], worst[2], worst[3], worst[4], worst[5]);
  for (double w : worst) EXPECT_LT(w, 1e-13) << name;
}

TEST(GeneratedFrames, UrdfRobotsMatchTheRecursiveImplementation) {
  compare_with_recursive<panda_frames::Kernels>("panda", "panda.urdf", false);
  compare_with_recursive<solo12_frames::Kernels>("solo12 (free)", "solo12.urdf", true);
}

// ---- the reference against differences, in dd_real -------------------------------------------

// Central differences along the free joint's exponential map (q ⊕ εu) with ε = 1e-12 in dd_real:
// truncation ~ε², rounding ~1e-32/ε, so agreement to ~1e-19 shows the derivatives are exact.
template <class Model> void reference_against_differences(const char* name) {
  using RD = eom::Reference<Model, dd_real>;
  constexpr int nq = RD::nq, nv = RD::nv, np = RD::np;
  std::mt19937_64 rng(11);
  std::vector<double> qd_, vd_;
  random_state<RD>(rng, qd_, vd_);
  std::array<dd_real, nq> q;
  std::array<dd_real, nv> v;
  std::array<dd_real, np> p;
  for (int i = 0; i < nq; ++i) q[i] = qd_[i];
  for (int i = 0; i < nv; ++i) v[i] = vd_[i];
  for (int i = 0; i < np; ++i) p[i] = RD::parameter_values[i];
  eom::normalize_configuration(eom::Layout(nq, nv), q.data());
  const dd_real eps("1e-12");
  auto moved = [&](const std::array<dd_real, nv>& u, const dd_real& h) {
    std::array<dd_real, nq> out;
    eom::integrate_configuration(eom::Layout(nq, nv), q.data(), u.data(), h, out.data());
    return out;
  };
  double worst_J = 0, worst_a = 0, worst_com = 0;
  for (int f = 0; f < RD::nframes; ++f) {
    std::array<dd_real, 6 * nv> J;
    std::array<dd_real, 6> a;
    RD::frame_jacobian(f, q.data(), p.data(), J.data());
    RD::frame_acceleration_bias(f, q.data(), v.data(), p.data(), a.data());
    for (int j = 0; j < nv; ++j) {
      std::array<dd_real, nv> e{};
      e[j] = 1.0;
      const auto qp = moved(e, eps), qm = moved(e, -eps);
      std::array<dd_real, 3> xp, xm;
      std::array<dd_real, 9> Rp, Rm, R0;
      std::array<dd_real, 3> x0;
      RD::frame_placement(f, qp.data(), p.data(), xp.data(), Rp.data());
      RD::frame_placement(f, qm.data(), p.data(), xm.data(), Rm.data());
      RD::frame_placement(f, q.data(), p.data(), x0.data(), R0.data());
      std::array<dd_real, 9> dR;
      for (int k = 0; k < 9; ++k) dR[k] = (Rp[k] - Rm[k]) / (2 * eps);
      const auto w = eom::detail::world_angular_velocity(R0, dR);
      for (int k = 0; k < 3; ++k) {
        worst_J = std::max(worst_J, to_double(abs((xp[k] - xm[k]) / (2 * eps) - J[k + 6 * j])));
        worst_J = std::max(worst_J, to_double(abs(w[k] - J[3 + k + 6 * j])));
      }
    }
    // a = d/dt (J v) along q(t) = q ⊕ t v, v held: the motion at v̇ = 0.
    std::array<dd_real, 6 * nv> Jp, Jm;
    const auto qp = moved(v, eps), qm = moved(v, -eps);
    RD::frame_jacobian(f, qp.data(), p.data(), Jp.data());
    RD::frame_jacobian(f, qm.data(), p.data(), Jm.data());
    for (int k = 0; k < 6; ++k) {
      dd_real d = 0.0;
      for (int j = 0; j < nv; ++j) d += (Jp[k + 6 * j] - Jm[k + 6 * j]) * v[j];
      worst_a = std::max(worst_a, to_double(abs(d / (2 * eps) - a[k])));
    }
  }
  // The mass centre's Jacobian, and the centroidal matrix's linear rows: the total mass times it.
  std::array<dd_real, 3 * nv> Jc;
  std::array<dd_real, 6 * nv> A;
  RD::center_of_mass_jacobian(q.data(), p.data(), Jc.data());
  RD::centroidal_momentum_matrix(q.data(), p.data(), A.data());
  std::array<eom::BodyOf<Model, dd_real>, Model::body_count> b;
  Model::template bodies<dd_real>(q, p, b);
  dd_real mass = 0.0;
  for (const auto& body : b) mass += body.mass;  // these models weld nothing to the world
  for (int j = 0; j < nv; ++j) {
    std::array<dd_real, nv> e{};
    e[j] = 1.0;
    const auto qp = moved(e, eps), qm = moved(e, -eps);
    std::array<dd_real, 3> cp, cm;
    RD::center_of_mass(qp.data(), p.data(), cp.data());
    RD::center_of_mass(qm.data(), p.data(), cm.data());
    for (int k = 0; k < 3; ++k) {
      worst_com = std::max(worst_com, to_double(abs((cp[k] - cm[k]) / (2 * eps) - Jc[k + 3 * j])));
      worst_com = std::max(worst_com, to_double(abs(A[k + 6 * j] - mass * Jc[k + 3 * j])));
    }
  }
  std::printf("%-18s J %.1e  J̇v %.1e  mass centre %.1e (against differences, dd_real)\n", name,
              worst_J, worst_a, worst_com);
  EXPECT_LT(worst_J, 1e-17) << name;
  EXPECT_LT(worst_a, 1e-17) << name;
  EXPECT_LT(worst_com, 1e-17) << name;
}

TEST(ReferenceFrames, AgreeWithDifferencesInDoubleDouble) {
  reference_against_differences<frames_test::FrameArm>("frame_arm");
  reference_against_differences<frames_test::FreeBodyFrames>("free_body_frames");
  reference_against_differences<frames_test::FreeTreeFrames>("free_tree_frames");
}

// The mass centre of the bodies that move: the Panda's link 0 is welded to the world.
TEST(ReferenceFrames, MassCentreWeighsTheMovingBodies) {
  using Model = eom::urdf_models::panda_frames;
  using R = eom::Reference<Model>;
  std::vector<double> q, v;
  std::mt19937_64 rng(5);
  random_state<R>(rng, q, v);
  const auto& p = R::parameter_values;
  const auto links = eom::tree_of<Model, double>(p);
  std::array<eom::SpatialBody<double>, Model::body_count> b;
  Model::bodies<double>(q, p, b);
  double m = 0, x[3] = {0, 0, 0};
  for (std::size_t i = 0; i < b.size(); ++i) {
    bool moves = false;
    for (int l = static_cast<int>(i); l >= 0; l = links[l].parent) moves = moves || links[l].coordinate >= 0;
    if (!moves) continue;
    m += b[i].mass;
    for (int k = 0; k < 3; ++k) x[k] += b[i].mass * b[i].position[k];
  }
  std::array<double, 3> com;
  R::center_of_mass(q.data(), p.data(), com.data());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(com[k], x[k] / m, 1e-15);
}

// ---- bad input --------------------------------------------------------------------------------

TEST(FramesBadInput, NonOrthonormalRotationIsRefusedAtGeneration) {
  try {
    eom::gen::check_model<frames_test::SkewedFrame>({});
    FAIL() << "no error";
  } catch (const eom::gen::TracerError& e) {
    EXPECT_NE(std::string(e.what()).find("frames: frame 'skewed': rotation is not orthonormal"),
              std::string::npos)
        << e.what();
  }
}

TEST(FramesBadInput, FramesNamesAreCheckedWithTheClosest) {
  eom::gen::TracerOptions o;
  using R = eom::Reference<eom::urdf_models::panda_frames>;
  const std::span<const std::string_view> names(R::frame_names);
  auto error = [&](std::vector<std::string> frames, std::span<const std::string_view> valid) {
    o.frames = std::move(frames);
    try {
      eom::gen::trace_request(o, valid);
    } catch (const eom::gen::TracerError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error({"panda_link9"}, names),
            "FRAMES: 'panda_link9' is not a frame of the model; did you mean 'panda_link0' or "
            "'panda_link1' or 'panda_link2'? (its frames: panda_link0, panda_link1, panda_link2, "
            "panda_link3, panda_link4, panda_link5, panda_link6, panda_link7, panda_link8)");
  EXPECT_NE(error({"panda_hand"}, names).find("not a frame of the model (its frames: panda_link0"),
            std::string::npos);
  EXPECT_EQ(error({"panda_link8", "panda_link8"}, names), "FRAMES names 'panda_link8' twice");
  EXPECT_NE(error({"tool"}, {}).find("the model declares no frames"), std::string::npos);
  o.frames = {"panda_link8", "panda_link0"};
  EXPECT_EQ(eom::gen::trace_request(o, names).frames, (std::vector<int>{8, 0}));
}

struct EnergyForm {
  static constexpr std::array coordinates{"x"};
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) { return 0.5 * qd[0] * qd[0]; }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) { return q[0] * q[0]; }
};

TEST(FramesBadInput, KernelsThatNeedFramesOrBodiesSaySo) {
  using namespace eom::gen;
  TracedModel arm = trace<frames_test::FrameArm>("arm", "FrameArm");
  const KernelId jacobian[] = {KernelId::frame_jacobian};
  try {
    build_kernels(arm, jacobian);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("frame_jacobian requested but FRAMES names no frame"),
              std::string::npos) << e.what();
  }
  TracedModel energy = trace<EnergyForm>("energy", "EnergyForm", {}, TraceRequest{{}, true, {}});
  const KernelId com[] = {KernelId::center_of_mass};
  try {
    build_kernels(energy, com);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("needs the body or tree form"), std::string::npos) << e.what();
  }
  // Only the frames named are traced.
  TracedModel tool = trace<frames_test::FrameArm>("arm", "FrameArm", {}, TraceRequest{{0}, false, {}});
  ASSERT_EQ(tool.frames.size(), 1u);
  EXPECT_EQ(tool.frames[0].name, "tool");
  EXPECT_TRUE(tool.center_of_mass.empty());
}

}  // namespace
