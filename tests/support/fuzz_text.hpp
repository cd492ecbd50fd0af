// The fuzz runs of the importers (tests/urdf/fuzz_urdf.cpp, tests/mjcf/fuzz_mjcf.cpp): small
// edits of a model file's text, a check of the header written from it, and the run itself.
//
// mutate_text: one to three of truncate, delete a span, repeat a span, flip a byte,
// replace a quoted value by one of `values`, swap two tags, insert one of `insertions` (after a
// tag where `after_tag`, else anywhere). `value_weight` and `insert_weight`: how many times as
// often as each other edit those two come (more of them keeps the XML whole, so that the file
// reaches the importer's own code). Deterministic for a given rng.
#pragma once

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <random>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

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

// The first "nan" or "inf" where the header's code has a number (not in a string literal or a
// comment, where a model's names go): a number it printed that C++ cannot read back; empty if
// none.
inline std::string non_finite_number(const std::string& header) {
  std::string code;  // the header less its string literals' and comments' text
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == '"') {
      for (++i; i < header.size() && header[i] != '"'; ++i)
        if (header[i] == '\\') ++i;
      code += ' ';
    } else if (header.compare(i, 2, "//") == 0) {
      i = std::min(header.find('\n', i), header.size()) - 1;
    } else {
      code += header[i];
    }
  }
  // where a number goes: after one of "={,(-+*" and before one of ",});*+-/" (a model named
  // "nan" makes `struct nan {`, `nan::` and such: names, not numbers)
  const auto before = [&](std::size_t at) {
    while (at > 0 && std::isspace(static_cast<unsigned char>(code[at - 1]))) --at;
    return at > 0 && std::string_view("={,(-+*").find(code[at - 1]) != std::string_view::npos;
  };
  const auto after = [&](std::size_t at) {
    while (at < code.size() && std::isspace(static_cast<unsigned char>(code[at]))) ++at;
    return at < code.size() && std::string_view(",});*+-/").find(code[at]) != std::string_view::npos;
  };
  for (const char* word : {"nan", "inf"})
    for (std::size_t at = code.find(word); at != std::string::npos; at = code.find(word, at + 1))
      if (before(at) && after(at + 3)) return code.substr(at > 20 ? at - 20 : 0, 40);
  return {};
}

// The run: each seed file (seeds) mutated `per_seed` times by mutate(text, rng), each case k given
// to import(k, mutated), which returns the header written from it or throws. A case must end in a
// header (a model in it, no non-finite number) or an Error whose message starts with `prefix`
// (the file's name or path); anything else stops the run, printing the case. Returns main's exit
// code; prints "<program>: N cases: M models, E clear errors" (the tests' pass expression).
template <class Error, class Mutate, class Import>
int fuzz_run(const char* program, int per_seed, std::span<char* const> seeds, std::uint64_t rng_seed,
             const std::string& prefix, Mutate&& mutate, Import&& import) {
  std::mt19937_64 rng(rng_seed);
  int models = 0, errors = 0;
  for (const char* seed : seeds) {
    std::ifstream in(seed, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in || text.str().empty()) {
      std::fprintf(stderr, "%s: cannot read %s\n", program, seed);
      return 2;
    }
    for (int k = 0; k < per_seed; ++k) {
      const std::string mutated = mutate(text.str(), rng);
      try {
        const std::string header = import(k, mutated);
        if (header.find("struct ") == std::string::npos) throw std::logic_error("no model in the header");
        if (const std::string at = non_finite_number(header); !at.empty())
          throw std::logic_error("a non-finite number in the header: '" + at + "'");
        ++models;
      } catch (const Error& e) {
        if (std::string(e.what()).rfind(prefix, 0) != 0) {
          std::fprintf(stderr, "%s: message without %s: %s\n", program, prefix.c_str(), e.what());
          return 1;
        }
        ++errors;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: case %d of %s: unexpected %s\n--- input ---\n%s\n", program, k, seed,
                     e.what(), mutated.c_str());
        return 1;
      }
    }
  }
  std::printf("%s: %d cases: %d models, %d clear errors\n", program, models + errors, models, errors);
  return 0;
}

}  // namespace eom::test
