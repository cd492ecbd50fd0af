// The demo's free-flying scenes (a free joint, eom/model/free_joint.hpp), each writing a CSV and a facts
// file for demo/plot.py and a line of the summary:
//
//   free_spacecraft   the spacecraft-boom deployment with a free-floating hub
//                     (models/spacecraft_free.hpp): the hub's attitude and drift while the boom
//                     unfolds, the total linear and angular momenta (conserved: no external force)
//   free_panda        the Panda on a free base in zero gravity moving its arm: the base
//                     counter-rotates, the total angular momentum stays at its initial value 0
//   solo12_fall       Solo12 (models/robots/solo12.urdf, FLOATING_BASE) falling with its joints
//                     limp: its mass centre on the exact parabola
#pragma once

#include <cstdio>
#include <filesystem>

bool simulate_free_flight(const std::filesystem::path& dir, std::FILE* summary);
