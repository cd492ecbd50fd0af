// MuJoCo as the peer in the tests (tests/mjcf, tests/mujoco_peer): its model and data owned, and
// the measure every comparison with it uses.
#pragma once

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace eom::test {

struct MujocoDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using MujocoModel = std::unique_ptr<mjModel, MujocoDeleter>;
using MujocoData = std::unique_ptr<mjData, MujocoDeleter>;

// max |a − b| / max |b| (the difference itself where b is 0).
inline double relative(const double* a, const double* b, int n) {
  double diff = 0, scale = 0;
  for (int i = 0; i < n; ++i) {
    diff = std::max(diff, std::abs(a[i] - b[i]));
    scale = std::max(scale, std::abs(b[i]));
  }
  return scale > 0 ? diff / scale : diff;
}

}  // namespace eom::test
