// The box pairs of the narrow phase (eom::collide: sphere–box, capsule–box, box–box) against
// MuJoCo's mj_collision on models/mjcf/boxes.xml, contact by contact at random crowded states, and
// the contact step (eom::contact_step) against mj_step with bodies let fall onto the boxes.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "contact_peer.hpp"
#include "mujoco_peer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <mjcf_boxes.hpp>
#include <mjcf_boxes_model.hpp>

#include <eom/contact/narrow_phase.hpp>
#include <eom/contact/solver.hpp>
#include <eom/contact/step.hpp>
#include <eom/multibody/tree.hpp>

namespace {

using eom::test::relative;
using Model = eom::mjcf_models::mjcf_boxes;
using K = mjcf_boxes::Kernels;

// A state with every body somewhere over the world's geoms (x, y in [−0.35, 0.35] × [−0.35,
// 0.25], z in [0, 0.2]), turned at random: the bodies on slides placed there whatever their own
// position, their hinges anywhere in [−3, 3].
void crowded(const mjModel* m, std::mt19937_64& rng, std::vector<double>& q) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const std::array<double, 3> centre{0, -0.05, 0.1}, spread{0.35, 0.3, 0.1};
  for (int j = 0; j < m->njnt; ++j) {
    const int a = m->jnt_qposadr[j];
    if (m->jnt_type[j] == mjJNT_FREE) {
      for (int k = 0; k < 3; ++k) q[a + k] = centre[k] + spread[k] * unit(rng);
      double n = 0;
      for (int k = 3; k < 7; ++k) n += (q[a + k] = unit(rng)) * q[a + k];
      for (int k = 3; k < 7; ++k) q[a + k] /= std::sqrt(n);
    } else if (m->jnt_type[j] == mjJNT_SLIDE) {  // along x, y or z: from the body's position
      int k = 0;
      while (m->jnt_axis[3 * j + k] == 0) ++k;
      q[a] = centre[k] + spread[k] * unit(rng) - m->body_pos[3 * m->jnt_bodyid[j] + k];
    } else {
      q[a] = 3.0 * unit(rng);
    }
  }
}

const char* shape_name(eom::Shape s) {
  switch (s) {
    case eom::Shape::plane: return "plane";
    case eom::Shape::sphere: return "sphere";
    case eom::Shape::capsule: return "capsule";
    case eom::Shape::box: return "box";
    default: return "other";
  }
}

// How well a contact is fixed by the geoms' placements, which differ from MuJoCo's by their
// rounding (~1e-16 m): the normal of a contact with a sphere or capsule is drawn between two
// points L = dist + radii apart (a sphere's centre and a box's point; a capsule's segment point
// found in a near-parallel case too), so that rounding moves it by ~1e-16 m / L. A difference is
// weighed by min(1, L / 1 cm): contacts a micron deep into a segment may differ by 1e-10 and be
// as right as MuJoCo's. A sphere centre inside a box (L ~ 0) leaves along an axis: weight 1.
double weight(const eom::Geom& a, const eom::Geom& b, double dist) {
  auto radius = [](const eom::Geom& g) {
    return g.shape == eom::Shape::sphere || g.shape == eom::Shape::capsule ? g.size[0] : 0.0;
  };
  const double L = dist + radius(a) + radius(b);
  if (a.shape == eom::Shape::plane || L < 1e-9) return 1.0;  // a plane's normal is its own
  return std::min(1.0, L / 0.01);
}

// Contacts between geoms against MuJoCo's mj_collision: the candidate pairs are those MuJoCo
// tests (every geom's margin so large that every pair it tests touches), in its order; at random
// crowded states, eom::collide on the geoms placed by the tree gives MuJoCo's contacts pair by
// pair: their number, distances, positions and frames, and on MuJoCo's own placements the same
// bits. Counted and measured per kind of pair; the pairs that give two contacts counted apart
// (capsule–box's second sphere: its heuristic's cases; box–box's faces and edges).
TEST(mjcf_boxes, PairsAndContactsAgreeWithMuJoCo) {
  eom::test::MujocoModel model(mj_loadXML(EOM_MJCF_BOXES, nullptr, nullptr, 0));
  ASSERT_TRUE(model);
  mjModel* m = model.get();
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();

  EXPECT_EQ(eom::test::candidate_pairs<Model>(), eom::test::tested_pairs(m));  // the candidates

  const auto links = eom::tree_of<Model, double>(Model::parameter_values);
  std::mt19937_64 rng(49);
  std::vector<double> q(m->nq);
  struct Kind {
    int contacts = 0, seconds = 0, most = 0;  // seconds: pairs that gave two contacts or more
    double worst = 0, weighed = 0, same = 0;
  };
  std::map<std::string, Kind> kinds;
  constexpr int samples = 20000;
  for (int sample = 0; sample < samples; ++sample) {
    crowded(m, rng, q);
    std::copy(q.begin(), q.end(), d->qpos);
    mj_forward(m, d);
    ASSERT_EQ(d->warning[mjWARN_CONTACTFULL].number, 0);
    const auto X = eom::test::tree_geom_placements<Model>(links, q);
    const auto mujocos = eom::test::mujoco_geom_placements<Model>(d);  // MuJoCo's own
    eom::test::compare_contacts<Model>(
        X, d,
        [&](const eom::CollisionPair& pair, const eom::Contact* ours, int n, const mjContact* theirs) {
          const eom::Geom &a = Model::geoms[pair.geom1], &b = Model::geoms[pair.geom2];
          eom::Contact same[eom::max_pair_contacts];
          const int n_same =
              eom::collide(a, mujocos[pair.geom1], b, mujocos[pair.geom2], pair.margin, same);
          Kind& kind = kinds[std::string(shape_name(a.shape)) + "–" + shape_name(b.shape)];
          kind.seconds += n > 1;
          kind.most = std::max(kind.most, n);
          for (int k = 0; k < n; ++k) {
            const double diff = eom::test::contact_difference(ours[k], theirs[k]);
            kind.worst = std::max(kind.worst, diff);
            kind.weighed = std::max(kind.weighed, diff * weight(a, b, theirs[k].dist));
            kind.same = n_same == n
                            ? std::max(kind.same, eom::test::contact_difference(same[k], theirs[k]))
                            : 1.0;
            ++kind.contacts;
          }
        });
    ASSERT_FALSE(HasFailure()) << "sample " << sample;
  }
  double weighed = 0, same = 0;  // the box pairs'; the others' are test_mjcf's
  for (const auto& [name, kind] : kinds) {
    std::printf("%s: %s, %d contacts over %d states (%d pairs with two or more, %d at most); "
                "eom::collide against MuJoCo: %.2e, weighed by how well the placements fix them "
                "%.2e, on MuJoCo's own placements %.2e\n",
                EOM_MJCF_BOXES, name.c_str(), kind.contacts, samples, kind.seconds, kind.most,
                kind.worst, kind.weighed, kind.same);
    if (name.ends_with("box") && !name.starts_with("plane"))
      weighed = std::max(weighed, kind.weighed);
    same = std::max(same, kind.same);
  }
  EXPECT_GE(kinds["sphere–box"].contacts, 5000);
  EXPECT_GE(kinds["capsule–box"].contacts, 5000);
  EXPECT_GE(kinds["capsule–box"].seconds, 1000);
  EXPECT_GE(kinds["box–box"].contacts, 5000);
  EXPECT_GE(kinds["box–box"].seconds, 1000);
  // 1.2e-13 measured (capsule–box, a near-parallel segment's point), 5.6e-14 when the bodies
  // moved by slides and hinges rather than free joints: rounding's spread, not a bound of the
  // arithmetic, which the next line holds to the bit
  EXPECT_LE(weighed, 2e-13);
  EXPECT_LE(same, 1e-15);  // the same arithmetic as MuJoCo's: here, the same bits
}

// The contact step (eom::contact_step) against mj_step, MuJoCo's Newton solver run to its limit
// (tolerance 1e-15, 200 iterations): from the bodies' own positions over the world's boxes,
// nudged and turned a little and set moving at random, 4 runs of 300 steps (0.6 s: the cube
// falls onto the plinth, the brick onto the tilted wedge, the ball and the stick onto them, the
// ground and each other, and they come to rest), q and v after every step
// and every contact's force in its frame (eom::contact_force against mj_contactForce).
TEST(mjcf_boxes, StepsAgreeWithMuJoCo) {
  eom::test::MujocoModel model(mj_loadXML(EOM_MJCF_BOXES, nullptr, nullptr, 0));
  ASSERT_TRUE(model);
  mjModel* m = model.get();
  m->opt.tolerance = 1e-15;
  m->opt.iterations = 200;
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  std::mt19937_64 rng(491);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::array<double, K::nq> q;
  std::array<double, K::nv> v;
  double worst = 0, forces = 0;
  int contacts = 0, box_contacts = 0, box_box = 0;  // box_contacts: of a box with a sphere,
                                                     // capsule or box; box_box: of two boxes
  for (int run = 0; run < 4; ++run) {
    mj_resetData(m, d);
    for (int j = 0; j < m->njnt; ++j) {
      const int a = m->jnt_qposadr[j];
      if (m->jnt_type[j] == mjJNT_FREE) {
        for (int k = 0; k < 3; ++k) d->qpos[a + k] += 0.02 * unit(rng);
        double n = 0;
        for (int k = 3; k < 7; ++k) {
          d->qpos[a + k] += 0.2 * unit(rng);
          n += d->qpos[a + k] * d->qpos[a + k];
        }
        for (int k = 3; k < 7; ++k) d->qpos[a + k] /= std::sqrt(n);
      } else {
        d->qpos[a] = (m->jnt_type[j] == mjJNT_SLIDE ? 0.02 : 0.3) * unit(rng);
      }
    }
    for (int i = 0; i < m->nv; ++i) d->qvel[i] = 0.5 * unit(rng);
    std::copy(d->qpos, d->qpos + K::nq, q.begin());
    std::copy(d->qvel, d->qvel + K::nv, v.begin());
    stepper->warm = false;
    double t = 0;
    for (int k = 0; k < 300; ++k) {
      mj_step(m, d);
      const auto status =
          eom::contact_step<K, Model>(*stepper, t, q, v, nullptr, K::parameter_values.data());
      ASSERT_EQ(status, eom::StepStatus::ok) << run << " " << k;
      worst = std::max(
          {worst, relative(q.data(), d->qpos, K::nq), relative(v.data(), d->qvel, K::nv)});
      ASSERT_EQ(stepper->rows.ncontacts, d->ncon) << run << " " << k;
      contacts += d->ncon;
      for (int c = 0; c < d->ncon; ++c) {
        const int g1 = d->contact[c].geom1, g2 = d->contact[c].geom2;
        box_contacts += m->geom_type[g2] == mjGEOM_BOX && m->geom_type[g1] != mjGEOM_PLANE;
        box_box += m->geom_type[g2] == mjGEOM_BOX && m->geom_type[g1] == mjGEOM_BOX;
      }
      forces = std::max(forces, eom::test::force_difference(m, d, *stepper));
    }
  }
  std::printf("%s: eom::contact_step against mj_step over 4 runs of 300 steps (%d contacts on the "
              "way, %d of a box with a sphere, capsule or box, %d of them box–box): q and v "
              "within %.2e (relative), contact forces within %.2e\n",
              EOM_MJCF_BOXES, contacts, box_contacts, box_box, worst, forces);
  EXPECT_GT(box_contacts, 1000);
  EXPECT_GT(box_box, 1000);
  EXPECT_LE(worst, 1e-11);
  EXPECT_LE(forces, 1e-10);
}

}  // namespace
