// Small edits of a model file's text for the fuzz runs of the importers (tests/urdf/fuzz_urdf.cpp,
// tests/mjcf/fuzz_mjcf.cpp): one to three of truncate, delete a span, repeat a span, flip a byte,
// replace a quoted value by one of `values`, swap two tags, insert one of `insertions` (after a
// tag where `after_tag`, else anywhere). `value_weight` and `insert_weight`: how many times as
// often as each other edit those two come (more of them keeps the XML whole, so that the file
// reaches the importer's own code). Deterministic for a given rng.
#pragma once

#include <algorithm>
#include <cstddef>
#include <random>
#include <span>
#include <string>

namespace eom::test {

inline std::string mutate_text(std::string s, std::mt19937_64& rng, std::span<const char* const> values,
                               std::span<const char* const> insertions, int value_weight = 1,
                               int insert_weight = 1, bool after_tag = false) {
  auto pick = [&rng](std::size_t n) { return n == 0 ? std::size_t{0} : std::size_t(rng() % n); };
  const int edits = 1 + int(rng() % 3);
  for (int e = 0; e < edits && !s.empty(); ++e) {
    const std::size_t a = pick(s.size()), b = a + pick(std::min<std::size_t>(64, s.size() - a));
    const int kind = int(rng() % std::size_t(5 + value_weight + insert_weight));
    if (kind == 0) {
      s.resize(a);  // truncate
    } else if (kind == 1) {
      s.erase(a, b - a);  // delete a span
    } else if (kind == 2) {
      s.insert(a, s.substr(a, b - a));  // repeat a span
    } else if (kind == 3) {
      s[a] = char(rng() % 256);  // flip a byte
    } else if (kind < 4 + value_weight) {  // replace a quoted value
      const std::size_t q1 = s.find('"', a);
      const std::size_t q2 = q1 == std::string::npos ? q1 : s.find('"', q1 + 1);
      if (q2 != std::string::npos) s.replace(q1 + 1, q2 - q1 - 1, values[pick(values.size())]);
    } else if (kind == 4 + value_weight) {  // swap two tags
      const std::size_t t1 = s.find('<', a), t2 = t1 == std::string::npos ? t1 : s.find('<', t1 + 1 + pick(200));
      if (t2 == std::string::npos) continue;
      const std::size_t e1 = s.find('>', t1), e2 = s.find('>', t2);
      if (e1 == std::string::npos || e2 == std::string::npos || e1 > t2) continue;
      const std::string tag1 = s.substr(t1, e1 - t1 + 1), tag2 = s.substr(t2, e2 - t2 + 1);
      s.replace(t2, tag2.size(), tag1);
      s.replace(t1, tag1.size(), tag2);
    } else {  // insert
      const std::size_t at = after_tag ? s.find('>', a) : a;
      if (at != std::string::npos) s.insert(after_tag ? at + 1 : at, insertions[pick(insertions.size())]);
    }
  }
  return s;
}

}  // namespace eom::test
