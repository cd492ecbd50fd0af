// The demo's contact scene: Solo12 dropped onto its four feet (a touchdown event, the impulse of
// its stance set), then standing on them while its joints sway the body (eom::OnContacts,
// eom/integration/contacts.hpp). Writes contacts.csv (base position, the feet's vertical forces,
// the feet's drift from where they touched) and contacts.txt for demo/plot.py, and a summary line.
#pragma once

#include <cstdio>
#include <filesystem>

bool simulate_contacts(const std::filesystem::path& dir, std::FILE* summary);

// Solo12 trotting: standing, then its diagonal pairs lifted (liftoffs), swung and put down
// (touchdown events and their impulses) in turn, six cycles. Writes trot.csv (base, normal
// forces, feet's heights, the set holding, the held feet's drift), trot_events.csv (liftoffs and
// touchdowns, impulses) and trot.txt for demo/plot.py, and a summary line.
bool simulate_trot(const std::filesystem::path& dir, std::FILE* summary);
