// The demo's simulation with contact as MuJoCo (eom::contact_step, eom/contact/step.hpp; issue 49):
// MuJoCo's humanoid falling onto the floor from its standing pose (contact forces, energy,
// penetration), a batch of random-control humanoid rollouts (eom::contact_rollout), and boxes
// launched down an incline that slide or stop as their friction coefficient against tan(angle)
// says (models/mjcf/incline_sweep.xml). Writes contact_humanoid.csv, contact_batch.csv,
// contact_incline.csv, contact_incline.txt and contact_simulation.txt for demo/plot.py.
#pragma once

#include <cstdio>
#include <filesystem>

bool simulate_contact_simulation(const std::filesystem::path& dir, std::FILE* summary);
