// The plane–cylinder and plane–ellipsoid pairs of the narrow phase (eom::collide) against MuJoCo's
// mj_collision on models/mjcf/rolling.xml, contact by contact at random states and on MuJoCo's
// rollouts, and the contact step (eom::contact_step) against mj_step: a coin rolling on its rim,
// a roller on its two ends, a disk on three rim points, an egg wobbling.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "contact_peer.hpp"
#include "mujoco_peer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <mjcf_rolling.hpp>
#include <mjcf_rolling_model.hpp>

#include <eom/contact/narrow_phase.hpp>
#include <eom/contact/solver.hpp>
#include <eom/contact/step.hpp>
#include <eom/multibody/tree.hpp>

namespace {

using Model = eom::mjcf_models::mjcf_rolling;
using K = mjcf_rolling::Kernels;

// Per kind of pair: contacts, pairs with several, the most of a pair, the worst difference on the
// tree's placements and on MuJoCo's own.
struct Kind {
  int contacts = 0, several = 0, most = 0;
  double worst = 0, same = 0;
};

// MuJoCo's contacts at its state in d (after mj_forward, or mj_step's at the state it started
// from, q) against eom::collide's on the tree's placements and on MuJoCo's own: counted into
// cylinder and ellipsoid.
void compare(const std::array<eom::TreeLink<double>, Model::link_count>& links,
             const std::vector<double>& q, const mjData* d, Kind& cylinder, Kind& ellipsoid) {
  const auto X = eom::test::tree_geom_placements<Model>(links, q);
  const auto mujocos = eom::test::mujoco_geom_placements<Model>(d);
  eom::test::compare_contacts<Model>(
      X, d, [&](const eom::CollisionPair& pair, const eom::Contact* ours, int n, const mjContact* theirs) {
        const eom::Geom &a = Model::geoms[pair.geom1], &b = Model::geoms[pair.geom2];
        eom::Contact same[eom::max_pair_contacts];
        const int n_same = eom::collide(a, mujocos[pair.geom1], b, mujocos[pair.geom2], pair.margin, same);
        Kind& kind = b.shape == eom::Shape::cylinder ? cylinder : ellipsoid;
        kind.several += n > 1;
        kind.most = std::max(kind.most, n);
        for (int k = 0; k < n; ++k, ++kind.contacts) {
          kind.worst = std::max(kind.worst, eom::test::contact_difference(ours[k], theirs[k]));
          kind.same = n_same == n ? std::max(kind.same, eom::test::contact_difference(same[k], theirs[k]))
                                  : 1.0;
        }
      });
}

// A unit quaternion turning z by `tilt` about a random horizontal axis, then about z at random.
void tilted(std::mt19937_64& rng, double tilt, double* quat) {
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  const double spin = angle(rng), across = angle(rng);
  const double a[4] = {std::cos(tilt / 2), std::sin(tilt / 2) * std::cos(across),
                       std::sin(tilt / 2) * std::sin(across), 0};
  const double b[4] = {std::cos(spin / 2), 0, 0, std::sin(spin / 2)};
  mju_mulQuat(quat, a, b);
}

// A state with the bodies over the floor near their places, within reach of it (and the coin,
// a third of the time, of the wall): free bodies turned anywhere, or a third of the time (the
// coin) 0.001 to 0.1 rad from lying flat (nearer, the rim points' direction is rounding's: see
// docs/CONTRACT.md), the slides from 1 cm above touching to 7 cm into the floor, the hinges
// anywhere.
void crowded(const mjModel* m, std::mt19937_64& rng, std::vector<double>& q) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), fraction(0.0, 1.0);
  for (int j = 0; j < m->njnt; ++j) {
    const int a = m->jnt_qposadr[j], body = m->jnt_bodyid[j];
    if (m->jnt_type[j] == mjJNT_FREE) {
      const double* home = m->body_pos + 3 * body;
      const double choice = fraction(rng);
      q[a] = home[0] + 0.1 * unit(rng) + (j == 0 && choice > 2.0 / 3 ? 0.7 : 0.0);
      q[a + 1] = home[1] + 0.1 * unit(rng);
      const double floor = std::tan(0.1) * q[a + 1];
      q[a + 2] = floor + m->geom_rbound[m->body_geomadr[body]] * (0.2 + 1.0 * fraction(rng));
      if (j == 0 && choice < 1.0 / 3) {  // the coin nearly flat on the floor
        double quat[4];
        tilted(rng, 0.001 + 0.099 * fraction(rng), quat);
        const double floor_turn[4] = {std::cos(0.05), std::sin(0.05), 0, 0};
        mju_mulQuat(q.data() + a + 3, floor_turn, quat);
        q[a + 2] = floor + 0.05 * fraction(rng);
      } else {
        double n = 0;
        for (int k = 3; k < 7; ++k) n += (q[a + k] = unit(rng)) * q[a + k];
        for (int k = 3; k < 7; ++k) q[a + k] /= std::sqrt(n);
      }
    } else if (m->jnt_type[j] == mjJNT_SLIDE) {  // from resting at the margin's edge
      q[a] = -0.03 + 0.04 * unit(rng);
    } else {
      q[a] = M_PI * unit(rng);
    }
  }
}

// Contacts against mj_collision: the candidates are the pairs MuJoCo tests, in its order, each
// of the bodies against each plane (none against another: contype and conaffinity); at random
// states eom::collide gives MuJoCo's contacts pair by pair (their number, distances, positions,
// frames), on MuJoCo's own placements to the bit.
TEST(mjcf_rolling, PairsAndContactsAgreeWithMuJoCo) {
  eom::test::MujocoModel model(mj_loadXML(EOM_MJCF_ROLLING, nullptr, nullptr, 0));
  ASSERT_TRUE(model);
  mjModel* m = model.get();
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  EXPECT_EQ(eom::test::candidate_pairs<Model>(), eom::test::tested_pairs(m));
  EXPECT_EQ(Model::collision_pairs.size(), 8u);
  const auto links = eom::tree_of<Model, double>(Model::parameter_values);
  std::mt19937_64 rng(4949);
  std::vector<double> q(m->nq);
  Kind cylinder, ellipsoid;
  constexpr int samples = 4000;
  for (int sample = 0; sample < samples; ++sample) {
    crowded(m, rng, q);
    std::copy(q.begin(), q.end(), d->qpos);
    mj_forward(m, d);
    compare(links, q, d, cylinder, ellipsoid);
    ASSERT_FALSE(HasFailure()) << "sample " << sample;
  }
  for (const auto& [name, kind] : {std::pair{"plane–cylinder", cylinder}, {"plane–ellipsoid", ellipsoid}})
    std::printf("%s: %s, %d contacts over %d states (%d pairs with several, %d at most); "
                "eom::collide against MuJoCo: %.2e, on MuJoCo's own placements %.2e\n",
                EOM_MJCF_ROLLING, name, kind.contacts, samples, kind.several, kind.most,
                kind.worst, kind.same);
  EXPECT_GE(cylinder.contacts, 5000);
  EXPECT_GE(cylinder.several, 1000);
  EXPECT_EQ(cylinder.most, 4);
  EXPECT_GE(ellipsoid.contacts, 1000);
  EXPECT_LE(std::max(cylinder.worst, ellipsoid.worst), 1e-12);
  EXPECT_LE(std::max(cylinder.same, ellipsoid.same), 1e-15);
}

// The contact step against mj_step, MuJoCo's Newton solver run to its limit (tolerance 1e-15,
// 200 iterations): the coin launched rolling on its rim (1 m/s, spun to match, more or less),
// the roller turning on its axle, the disk turning on its hinge, the egg tossed spinning; 3 runs
// of 300 steps (0.6 s), q and v after every step, every contact's force in its frame, and on
// MuJoCo's states the contacts of mj_step's collision against eom::collide's.
TEST(mjcf_rolling, StepsAgreeWithMuJoCo) {
  eom::test::SideBySide<K, Model> sim(EOM_MJCF_ROLLING);
  ASSERT_TRUE(sim.model);
  const mjModel* m = sim.model.get();
  const mjData* d = sim.data.get();
  std::mt19937_64 rng(4950);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> before(K::nq), v0(K::nv);
  double worst = 0, forces = 0;
  int contacts = 0;
  Kind cylinder, ellipsoid;
  for (int run = 0; run < 3; ++run) {
    // coin: 6 (free), roller: drop, axle, disk: sink, turn, egg: 6 (free)
    const double kick[K::nv] = {1, 0, 0, 0, 0, 10, 0, 20, 0, 5, 0, 0, 0.5, 3, 2, 0};
    for (int i = 0; i < K::nv; ++i) v0[i] = kick[i] * (1 + 0.2 * unit(rng));
    sim.start(m->qpos0, v0.data());
    for (int k = 0; k < 300; ++k) {
      std::copy(d->qpos, d->qpos + K::nq, before.begin());
      const auto [status, difference] = sim.step();
      compare(sim.stepper->links, before, d, cylinder, ellipsoid);
      ASSERT_FALSE(HasFailure()) << run << " " << k;
      ASSERT_EQ(status, eom::StepStatus::ok) << run << " " << k;
      worst = std::max(worst, difference);
      ASSERT_EQ(sim.stepper->rows.ncontacts, d->ncon) << run << " " << k;
      contacts += d->ncon;
      forces = std::max(forces, eom::test::force_difference(m, d, *sim.stepper));
    }
  }
  std::printf("%s: eom::contact_step against mj_step over 3 runs of 300 steps (%d contacts, %d of "
              "a cylinder, %d pairs with several, %d of the ellipsoid): q and v within %.2e "
              "(relative), contact forces within %.2e; on MuJoCo's states eom::collide within "
              "%.2e (cylinder), %.2e (ellipsoid)\n",
              EOM_MJCF_ROLLING, contacts, cylinder.contacts, cylinder.several, ellipsoid.contacts,
              worst, forces, cylinder.worst, ellipsoid.worst);
  EXPECT_GT(cylinder.several, 300);
  EXPECT_GT(ellipsoid.contacts, 300);
  EXPECT_LE(std::max(cylinder.worst, ellipsoid.worst), 1e-12);
  EXPECT_LE(worst, 1e-10);
  EXPECT_LE(forces, 1e-9);
}

}  // namespace
