// MuJoCo as the peer in the tests (tests/mjcf, tests/mujoco_peer): its model and data owned, and
// the measure every comparison with it uses.
#pragma once

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace eom::test {

struct MujocoDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using MujocoModel = std::unique_ptr<mjModel, MujocoDeleter>;
using MujocoData = std::unique_ptr<mjData, MujocoDeleter>;

// MuJoCo's model of the MJCF `text`, loaded as the file `name` from a virtual file system; null
// where MuJoCo refuses it, its message in `error` (of `size` bytes).
inline MujocoModel load_text(const char* name, const std::string& text, char* error, int size) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), name, static_cast<int>(text.size())) != 0) return nullptr;
  std::memcpy(vfs->filedata[0], text.data(), text.size());
  MujocoModel m(mj_loadXML(name, vfs.get(), error, size));
  mj_deleteVFS(vfs.get());
  return m;
}

// max |a − b| / max |b| (the difference itself where b is 0).
inline double relative(const double* a, const double* b, int n) {
  double diff = 0, scale = 0;
  for (int i = 0; i < n; ++i) {
    diff = std::max(diff, std::abs(a[i] - b[i]));
    scale = std::max(scale, std::abs(b[i]));
  }
  return scale > 0 ? diff / scale : diff;
}

// The geom pairs MuJoCo's collision pipeline tests at m's qpos0, in its order (geom1, geom2): the
// pairs that touch when every geom's and <pair>'s margin is so large that every pair tested does.
inline std::vector<std::array<int, 2>> tested_pairs(const mjModel* m) {
  MujocoModel wide(mj_copyModel(nullptr, m));
  for (int g = 0; g < wide->ngeom; ++g) wide->geom_margin[g] = 100;
  for (int k = 0; k < wide->npair; ++k) wide->pair_margin[k] = 100;
  MujocoData data(mj_makeData(wide.get()));
  mj_forward(wide.get(), data.get());
  std::vector<std::array<int, 2>> tested;
  for (int i = 0; i < data->ncon; ++i) {
    const std::array<int, 2> pair{data->contact[i].geom1, data->contact[i].geom2};
    if (tested.empty() || tested.back() != pair) tested.push_back(pair);
  }
  return tested;
}

}  // namespace eom::test
