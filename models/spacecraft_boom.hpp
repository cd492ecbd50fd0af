// A spacecraft deploying a hinged boom in 3D: the paper's inflated-beam deployment (models/chain.hpp,
// Chain<10>) carried into space and onto a hub that is free to rotate. Written in the spatial body
// form (eom::SpatialBody, eom/multibody/spatial.hpp): one line per joint, T derived from the poses alone.
//
//   SpacecraftBoom   a rigid hub whose mass centre is fixed in inertial space (at the origin; an
//                    idealization: a free hub would drift by a few cm as the boom's 6 kg moves) and
//                    which is free to rotate about it, and a boom of 6 identical links joined by
//                    hinges whose axes alternate between z and y (so the boom folds and unfolds in
//                    3D, not in one plane). No gravity and no external force or torque act, so the
//                    angular momentum about the origin is conserved (eom/multibody/momentum.hpp); hinge
//                    springs drive the deployment and hinge dampers dissipate its energy.
//
// Coordinates (9):
//   hub_z, hub_x, hub_y   the hub's attitude, Euler angles of the sequence z-x-y (3-1-2):
//                           R_hub = Rz(hub_z) · Rx(hub_x) · Ry(hub_y)
//                         i.e. turn about the hub's z, then its new x, then its new y. The angles
//                         are singular where the middle rotation is ±90° (cos hub_x = 0: the first
//                         and last axes line up, M loses rank). The sequence is chosen so that
//                           - the nominal attitude (identity) is as far from the singularity as
//                             possible (all angles 0, hub_x 90° away; a proper Euler sequence such
//                             as 3-1-3 is singular right there), and
//                           - the middle axis is the boom's axis x: the boom's mass stays near the x
//                             axis and its hinges turn about z and y, so the hub is disturbed least
//                             about x (the demo's deployment: max |hub_x| 2.2° against 8.7° and
//                             11.3° for hub_z and hub_y, i.e. 87.8° from the singularity). Not a
//                             law: with weak springs (k = 0.2, c = 0.15) the unfolding turns the hub
//                             most about x.
//   hinge1 .. hinge6      the relative angle of link k to its parent (the hub for k = 1) about the
//                         hinge axis, 0 when straight. Hinge 1 is at the hub's face, r_root along the
//                         hub's x axis, and turns about the hub's z; hinge k+1 is at the tip of link
//                         k and turns about link k's z (k even) or y (k odd): axes z, y, z, y, z, y.
//
// Each link is a thin-walled tube (mass m_link, length l_link, radius r_link) along its own x axis,
// mass centre at mid-length: I_axial = m r², I_transverse = m l²/12 + m r²/2.
//
// Hinge k carries a torsion spring of stiffness k_hinge with its rest angle at 0 (straight: the
// spring stands in for the inflation pressure that unfolds the paper's inflated beam), V = ½ k Σ qₖ²,
// and a damper c_hinge on the relative rate of the two bodies it joins. Since hinge k's coordinate
// *is* that relative angle, the damper's equal and opposite torques (−c ωₖ on link k, +c ωₖ on its
// parent, ωₖ = q̇ₖ about the hinge axis) do virtual work −c q̇ₖ δqₖ: Qₖ = −c q̇ₖ on the hinge
// coordinate alone and nothing on the hub's angles (the chain's two-term form, models/chain.hpp, is
// the same law written in absolute angles). Power −Σ c q̇ₖ² ≤ 0; the torques are internal, so they
// leave the angular momentum unchanged.
//
// Defaults: a hub of 500 kg (a box of roughly 1.6-2 m) with principal inertia (300, 350, 400) kg·m²
// in its body axes, the boom root on its +x face, 0.8 m from its centre; links of 1 kg, 1 m, 5 cm radius; k = 2 N·m/rad (47 J
// stored when stowed), c = 8 N·m·s (the outer hinges overdamped, the whole boom's slow swing on
// the root hinges underdamped: deployed in ≈ 10 s, settled in ≈ 60 s). The hub's mass enters
// neither T nor H (its centre does not move).
//
// Stowed (initial_q): the hub at the identity attitude, the boom folded as a 3D accordion in front of
// the hub's +x face: link 1 at 5° from the x axis, each later hinge folded to ±175° (alternating
// sign), everything at rest (H = 0).
#pragma once

#include <array>
#include <numbers>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>

namespace eom::models {

struct SpacecraftBoom {
  static constexpr int links = 6;
  static constexpr std::array coordinates{"hub_z",  "hub_x",  "hub_y",  "hinge1", "hinge2",
                                          "hinge3", "hinge4", "hinge5", "hinge6"};
  static constexpr std::array parameters{"m_hub",  "Ixx_hub", "Iyy_hub", "Izz_hub",
                                         "r_root", "m_link",  "l_link",  "r_link",
                                         "k_hinge", "c_hinge"};
  static constexpr std::array parameter_values{500.0, 300.0, 350.0, 400.0, 0.8,
                                               1.0,   1.0,   0.05,  2.0,   8.0};
  static constexpr int body_count = 1 + links;  // hub, link 1 .. link 6

  // Hinge k's axis in its parent's frame: z, y, z, y, z, y.
  static constexpr std::array<double, 3> hinge_axis(int k) {
    return k % 2 == 0 ? std::array<double, 3>{0, 0, 1} : std::array<double, 3>{0, 1, 0};
  }

  // The stowed start (see above).
  static constexpr std::array<double, 9> initial_q = [] {
    constexpr double deg = std::numbers::pi / 180.0;
    std::array<double, 9> q{};
    q[3] = 5.0 * deg;
    for (int k = 1; k < links; ++k) q[3 + k] = (k % 2 == 1 ? 175.0 : -175.0) * deg;
    return q;
  }();

  template <class S> static void bodies(In<S> q, In<S> p, Out<SpatialBody<S>> b) {
    const S &m_hub = p[0], &r_root = p[4], &m = p[5], &l = p[6], &r = p[7];
    const S zero(0);
    const S axial = m * r * r, transverse = m * l * l / 12.0 + 0.5 * m * r * r;
    const std::array<S, 6> link_inertia{axial, transverse, transverse, zero, zero, zero};
    const Transform<S> along_link = translation<S>({l, zero, zero});  // joint k → joint k+1
    const Transform<S> mid_link = translation<S>({0.5 * l, zero, zero});

    // The hub: attitude z-x-y, mass centre fixed at the origin.
    const Transform<S> hub = rotation(multiply(rot_z(q[0]), multiply(rot_x(q[1]), rot_y(q[2]))));
    b[0] = rigid_body(hub, m_hub, {p[1], p[2], p[3], zero, zero, zero});

    // The boom: one line per joint.
    Transform<S> frame = hub * translation<S>({r_root, zero, zero}) * revolute(hinge_axis(0), q[3]);
    b[1] = rigid_body(frame, m, link_inertia, mid_link);
    for (int k = 1; k < links; ++k) {
      frame = frame * along_link * revolute(hinge_axis(k), q[3 + k]);
      b[1 + k] = rigid_body(frame, m, link_inertia, mid_link);
    }
  }

  // The hinge springs (no gravity in orbit).
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    S sum(0);
    for (int k = 0; k < links; ++k) sum = sum + q[3 + k] * q[3 + k];
    return 0.5 * p[8] * sum;
  }

  // The hinge dampers: Qₖ = −c q̇ₖ on the relative hinge rates; no torque on the hub's angles.
  template <class S>
  static void generalized_forces(const S&, In<S>, In<S> qd, In<S>, In<S> p, Out<S> Q) {
    for (int i = 0; i < 3; ++i) Q[i] = S(0);
    for (int k = 0; k < links; ++k) Q[3 + k] = -p[9] * qd[3 + k];
  }
};

}  // namespace eom::models
