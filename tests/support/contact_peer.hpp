// The narrow phase and the contact step against MuJoCo (tests/mjcf): a model's geoms placed by its
// tree or by MuJoCo, eom::collide run pair by pair over the model's collision_pairs beside
// MuJoCo's contacts at the same state (each of ours handed with MuJoCo's to the test's measure),
// and a step's contact forces beside mj_contactForce's.
#pragma once

#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "mujoco_peer.hpp"

#include <eom/contact/narrow_phase.hpp>
#include <eom/contact/solver.hpp>
#include <eom/contact/step.hpp>
#include <eom/model/model.hpp>
#include <eom/multibody/tree.hpp>

namespace eom::test {

template <class Model> using GeomPlacements = std::array<Transform<double>, Model::geoms.size()>;

// Model's candidate pairs (geom1, geom2), in its order: to hold against tested_pairs (MuJoCo's).
template <class Model> std::vector<std::array<int, 2>> candidate_pairs() {
  std::vector<std::array<int, 2>> out;
  for (const CollisionPair& x : Model::collision_pairs) out.push_back({x.geom1, x.geom2});
  return out;
}

// Each geom of Model in the world at q, placed by the tree `links` (eom's arithmetic).
template <class Model, std::size_t N>
GeomPlacements<Model> tree_geom_placements(const std::array<TreeLink<double>, N>& links,
                                           In<double> q) {
  const auto X = tree_placements<double>(links, q);
  GeomPlacements<Model> out;
  for (std::size_t g = 0; g < out.size(); ++g) {
    const Geom& x = Model::geoms[g];
    const Transform<double> on{x.rotation, x.position};
    out[g] = x.link < 0 ? on : X[x.link] * on;
  }
  return out;
}

// Each geom of Model as MuJoCo placed it (geom_xpos, geom_xmat: row-major, ours column-major).
template <class Model> GeomPlacements<Model> mujoco_geom_placements(const mjData* d) {
  GeomPlacements<Model> out;
  for (std::size_t g = 0; g < out.size(); ++g)
    for (int i = 0; i < 3; ++i) {
      out[g].translation[i] = d->geom_xpos[3 * g + i];
      for (int j = 0; j < 3; ++j) out[g].rotation[i + 3 * j] = d->geom_xmat[9 * g + 3 * i + j];
    }
  return out;
}

// How far a contact of ours is from MuJoCo's: the largest of the distances' difference and the
// positions' and frames' relative differences.
inline double contact_difference(const Contact& ours, const mjContact& theirs) {
  return std::max({std::abs(ours.dist - theirs.dist), relative(ours.pos.data(), theirs.pos, 3),
                   relative(ours.frame.data(), theirs.frame, 9)});
}

// A state of models/mjcf/primitives.xml with its bodies apart on a grid a little above the
// planes, turned a little (three hinges in a row lock where the middle one turns a quarter), the
// hinged handle within its limits: a scene to let fall.
inline void spread(const mjModel* m, std::mt19937_64& rng, std::vector<double>& q) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int slide = 0;
  for (int j = 0; j < m->njnt; ++j) {
    const int a = m->jnt_qposadr[j];
    if (m->jnt_type[j] == mjJNT_FREE) {
      q[a] = -0.4, q[a + 1] = 0.4, q[a + 2] = 0.3;
      double n = 0;
      for (int k = 3; k < 7; ++k) n += (q[a + k] = unit(rng)) * q[a + k];
      for (int k = 3; k < 7; ++k) q[a + k] /= std::sqrt(n);
    } else if (m->jnt_type[j] == mjJNT_SLIDE) {  // bodies of three slides (x, y, z), in turn
      const int body = slide / 3, axis = slide % 3;
      q[a] = axis == 0 ? 0.4 * (body % 3 - 1) : axis == 1 ? 0.4 * (body / 3) - 0.2 : 0.1 + 0.05 * unit(rng);
      ++slide;
    } else {
      q[a] = m->jnt_limited[j] ? 0.5 * (m->jnt_range[2 * j] + m->jnt_range[2 * j + 1]) : 0.5 * unit(rng);
    }
  }
}

// eom::collide on every pair of Model's collision_pairs at placements X, beside MuJoCo's contacts
// in d (after mj_forward or mj_collision at the same state), which come pair by pair in the same
// order: each pair modeled, at most pair_contacts of its shapes, MuJoCo's contacts of the same
// geoms, every one of MuJoCo's accounted for. visit(pair, ours, n, theirs) is called per pair
// that gives contacts (n of ours, MuJoCo's n from theirs on); `what` names the state in messages.
// Returns the contacts compared (on a fatal failure, the test's ASSERT has returned early).
template <class Model, class Visit>
int compare_contacts(const GeomPlacements<Model>& X, const mjData* d, Visit&& visit,
                     const char* what = "") {
  int at = 0;
  for (const CollisionPair& pair : Model::collision_pairs) {
    const Geom &a = Model::geoms[pair.geom1], &b = Model::geoms[pair.geom2];
    Contact ours[max_pair_contacts];
    const int n = collide(a, X[pair.geom1], b, X[pair.geom2], pair.margin, ours);
    EXPECT_GE(n, 0) << a.name << " " << b.name << " " << what;
    EXPECT_LE(n, pair_contacts(a.shape, b.shape)) << a.name << " " << b.name << " " << what;
    if (n <= 0) continue;
    EXPECT_LE(at + n, d->ncon) << a.name << " " << b.name << " " << what;
    if (at + n > d->ncon) return at;
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(d->contact[at + k].geom1, pair.geom1) << what;
      EXPECT_EQ(d->contact[at + k].geom2, pair.geom2) << what;
    }
    visit(pair, ours, n, d->contact + at);
    at += n;
  }
  EXPECT_EQ(at, d->ncon) << "MuJoCo found contacts eom::collide did not " << what;
  return at;
}

// MuJoCo's model of file, its Newton solver run to its limit (tolerance 1e-15, 200 iterations).
inline MujocoModel solver_run_to_its_limit(const char* file) {
  MujocoModel model(mj_loadXML(file, nullptr, nullptr, 0));
  if (model) {
    model->opt.tolerance = 1e-15;
    model->opt.iterations = 200;
  }
  return model;
}

// eom::contact_step beside mj_step on one file, MuJoCo's solver run to its limit: both started
// from the same (q, v) and stepped together.
template <class K, class Model> struct SideBySide {
  MujocoModel model;
  MujocoData data;
  std::unique_ptr<ContactStepper<K, Model>> stepper = std::make_unique<ContactStepper<K, Model>>();
  std::array<double, K::nq> q{};
  std::array<double, K::nv> v{};
  double t = 0;

  explicit SideBySide(const char* file)
      : model(solver_run_to_its_limit(file)), data(model ? mj_makeData(model.get()) : nullptr) {}
  void start(const double* q0, const double* v0) {
    mj_resetData(model.get(), data.get());
    std::copy(q0, q0 + K::nq, q.begin());
    std::copy(v0, v0 + K::nv, v.begin());
    std::copy(q.begin(), q.end(), data->qpos);
    std::copy(v.begin(), v.end(), data->qvel);
    t = 0;
    stepper->warm = false;
  }
  // One step of each (u: K's inputs, MuJoCo's ctrl left at zero, as here); eomgen's status, and
  // the larger relative difference of q and v after it.
  std::pair<StepStatus, double> step(const double* u = nullptr) {
    mj_step(model.get(), data.get());
    const auto status = contact_step<K, Model>(*stepper, t, q, v, u, K::parameter_values.data());
    return {status, std::max(relative(q.data(), data->qpos, K::nq),
                             relative(v.data(), data->qvel, K::nv))};
  }
};

// The largest difference of a step's contact forces (eom::contact_force, after contact_step) from
// mj_contactForce's (after mj_step from the same state), each relative to the larger of 1 and
// the contact's largest component; the contacts the same in number and order.
template <class K, class Model>
double force_difference(const mjModel* m, const mjData* d, const ContactStepper<K, Model>& stepper) {
  double worst = 0;
  for (int c = 0; c < d->ncon; ++c) {
    mjtNum theirs[6];
    mj_contactForce(m, d, c, theirs);
    const auto ours = contact_force<Model>(stepper.rows, stepper.solution, c);
    double scale = 1;
    for (double x : theirs) scale = std::max(scale, std::abs(x));
    for (int i = 0; i < 6; ++i) worst = std::max(worst, std::abs(ours[i] - theirs[i]) / scale);
  }
  return worst;
}

}  // namespace eom::test
