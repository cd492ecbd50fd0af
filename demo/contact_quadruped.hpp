// Solo12 on MuJoCo's soft contact (eom::contact_step over the scene of
// models/robots/solo12_feet.urdf with GROUND): dropped onto its foot spheres, standing for a
// second under a joint PD with gravity compensation, then trotting forward on an open-loop gait.
// Writes contact_quadruped.csv (base position, each foot's normal force, the deepest penetration,
// kinetic and gravitational energy) and contact_quadruped.txt for demo/plot.py, and a summary line.
#pragma once

#include <cstdio>
#include <filesystem>

bool simulate_contact_quadruped(const std::filesystem::path& dir, std::FILE* summary);
