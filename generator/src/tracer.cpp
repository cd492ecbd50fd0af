#include "eomgen/tracer.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>

#include "eomgen/emit.hpp"
#include "eomgen/write_file.hpp"

namespace eom::gen {
namespace {

bool is_identifier(std::string_view s) {
  if (s.empty() || (s[0] >= '0' && s[0] <= '9')) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_'))
      return false;
  return true;
}

bool is_qualified_identifier(std::string_view s) {
  for (std::size_t start = 0;;) {
    const std::size_t end = s.find("::", start);
    if (!is_identifier(s.substr(start, end - start))) return false;
    if (end == std::string_view::npos) return true;
    start = end + 2;
  }
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

std::string valid_kernel_names() {
  std::vector<std::string> names;
  for (int i = 0; i < kernel_count; ++i)
    names.emplace_back(signature(static_cast<KernelId>(i)).name);
  return join(names);
}


}  // namespace

void parse_tracer_arguments(int argc, char** argv, TracerOptions& o) {
  std::vector<std::string> problems;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--list-kernels") {
      o.list_kernels = true;
      continue;
    }
    if (i + 1 >= argc) throw TracerError("missing value after " + std::string(a));
    const std::string v = argv[++i];
    if (a == "--name") o.name = v;
    else if (a == "--class") o.class_name = v;
    else if (a == "--namespace") o.ns = v;
    else if (a == "--out-dir") o.out_dir = v;
    else if (a == "--kernel") o.kernels.push_back(v);
    else if (a == "--fixed") o.fixed.push_back(v);
    else if (a == "--frame") o.frames.push_back(v);
    else if (a == "--contact") o.contacts.push_back(v);
    else if (a == "--free") o.free.push_back(v);
    else if (a == "--solve" && v == "unrolled") o.solve = SolveForm::unrolled;
    else if (a == "--solve" && v == "looped") o.solve = SolveForm::looped;
    else if (a == "--solve" && v == "automatic") o.solve = SolveForm::automatic;
    else if (a == "--solve") problems.push_back("--solve takes unrolled, looped or automatic, not " + v);
    else if (a == "--batch-lanes" && (v == "2" || v == "4" || v == "8")) o.batch_lanes = v[0] - '0';
    else if (a == "--batch-lanes") problems.push_back("--batch-lanes takes 2, 4 or 8, not " + v);
    else problems.push_back("unknown argument " + std::string(a));
  }
  if (!problems.empty()) throw TracerError(join(problems));
  if (o.list_kernels) return;  // needs the model only
  if (o.name == "?" || o.name.empty()) throw TracerError("missing --name <name>");
  if (o.name.find_first_of("/\\") != std::string::npos)
    throw TracerError("--name must be a plain file name, not a path: " + o.name);
  if (o.ns.empty()) o.ns = o.name;
  if (!is_qualified_identifier(o.ns))
    throw TracerError("the namespace '" + o.ns +
                      "' is not a C++ (qualified) identifier; give --namespace (NAMESPACE)");
  if (o.out_dir.empty()) throw TracerError("missing --out-dir <dir>");
}

std::vector<std::optional<double>> resolve_fixed(const TracerOptions& o,
                                                 std::span<const std::string_view> parameters,
                                                 std::span<const double> defaults) {
  std::vector<std::optional<double>> fixed(parameters.size());
  auto index = [&](const std::string& name, const char* option) {
    std::size_t i = 0;
    while (i < parameters.size() && parameters[i] != name) ++i;
    if (i == parameters.size()) {
      std::vector<std::string> names(parameters.begin(), parameters.end());
      throw TracerError(std::string(option) + ": unknown parameter '" + name + "'" +
                        did_you_mean(name, parameters) + " (" +
                        (names.empty() ? std::string("the model has no parameters")
                                       : "the model's parameters: " + join(names)) + ")");
    }
    return i;
  };
  const bool all = std::count(o.fixed.begin(), o.fixed.end(), "ALL") > 0;
  if (std::count(o.fixed.begin(), o.fixed.end(), "ALL") > 1)
    throw TracerError("FIXED_PARAMETERS gives ALL twice");
  if (!o.free.empty() && !all)
    throw TracerError("FREE_PARAMETERS names the exceptions to FIXED_PARAMETERS ALL, which is not given");
  if (all)
    for (std::size_t i = 0; i < parameters.size() && i < defaults.size(); ++i) fixed[i] = defaults[i];
  std::vector<bool> given(parameters.size(), false);
  for (const std::string& f : o.fixed) {
    if (f == "ALL") continue;
    const std::size_t eq = f.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == f.size())
      throw TracerError("malformed FIXED_PARAMETERS entry '" + f + "': expected <param>=<value> or ALL");
    const std::string name = f.substr(0, eq), text = f.substr(eq + 1);
    double value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size())
      throw TracerError("malformed FIXED_PARAMETERS entry '" + f + "': '" + text +
                        "' is not a number");
    if (!std::isfinite(value))
      throw TracerError("FIXED_PARAMETERS entry '" + f + "': the value must be finite");
    const std::size_t i = index(name, "FIXED_PARAMETERS");
    if (given[i]) throw TracerError("FIXED_PARAMETERS: parameter '" + name + "' given twice");
    given[i] = true;
    fixed[i] = value;  // with ALL: this value instead of the default
  }
  for (const std::string& name : o.free) {
    const std::size_t i = index(name, "FREE_PARAMETERS");
    if (given[i])
      throw TracerError("parameter '" + name + "' is both in FIXED_PARAMETERS (with a value) and "
                        "in FREE_PARAMETERS");
    if (!fixed[i]) throw TracerError("FREE_PARAMETERS: parameter '" + name + "' given twice");
    fixed[i].reset();
  }
  return fixed;
}

std::string did_you_mean(std::string_view name, std::span<const std::string_view> valid) {
  auto distance = [](std::string_view a, std::string_view b) {  // Levenshtein, one row
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t up = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
        diagonal = up;
      }
    }
    return row[b.size()];
  };
  // The closest names, if they are close: at most a third of the name's length apart (at least 2
  // edits). Ties all shown, up to three.
  const std::size_t limit = std::max<std::size_t>(2, name.size() / 3);
  std::size_t best = limit + 1;
  for (std::string_view v : valid) best = std::min(best, distance(name, v));
  std::vector<std::string_view> close;
  for (std::string_view v : valid)
    if (best <= limit && distance(name, v) == best && close.size() < 3) close.push_back(v);
  if (close.empty()) return "";
  std::string s = "; did you mean";
  for (std::size_t i = 0; i < close.size(); ++i) s += (i == 0 ? " '" : " or '") + std::string(close[i]) + "'";
  return s + "?";
}

namespace {

// The index of frame `name` in the model's frame_names, or a TracerError from `keyword` naming
// the closest frames.
int frame_index(std::string_view keyword, const std::string& name, std::span<const std::string_view> frame_names) {
  const auto at = std::find(frame_names.begin(), frame_names.end(), name);
  if (at != frame_names.end()) return static_cast<int>(at - frame_names.begin());
  if (frame_names.empty())
    throw TracerError(std::string(keyword) + " names '" + name + "', but the model declares no frames "
                      "(give it `frame_names` and `frames()`, or in the tree form `link_frames()`)");
  std::string listed;
  for (std::size_t i = 0; i < std::min<std::size_t>(frame_names.size(), 12); ++i)
    listed += (i ? ", " : "") + std::string(frame_names[i]);
  if (frame_names.size() > 12) listed += ", ... (" + std::to_string(frame_names.size()) + " in all)";
  throw TracerError(std::string(keyword) + ": '" + name + "' is not a frame of the model" +
                    did_you_mean(name, frame_names) + " (its frames: " + listed + ")");
}

}  // namespace

TraceRequest trace_request(const TracerOptions& o, std::span<const std::string_view> frame_names) {
  TraceRequest r;
  for (const std::string& name : o.frames) {
    const int f = frame_index("FRAMES", name, frame_names);
    if (std::find(r.frames.begin(), r.frames.end(), f) != r.frames.end())
      throw TracerError("FRAMES names '" + name + "' twice");
    r.frames.push_back(f);
  }
  // CONTACTS: <set>=<frame>[:6d],... ; a set's frames join the frames if FRAMES left them out.
  for (const std::string& entry : o.contacts) {
    const std::size_t eq = entry.find('=');
    const std::string set = entry.substr(0, eq);
    const std::string usage = " (expected <set>=<frame>[:6d][,<frame>[:6d]...], e.g. "
                              "stance=FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT)";
    if (eq == std::string::npos || !is_identifier(set))
      throw TracerError("CONTACTS entry '" + entry + "' is malformed: it does not start with a set "
                        "name (a C++ identifier) and '='" + usage);
    for (const auto& other : r.contact_sets)
      if (other.name == set) throw TracerError("CONTACTS names the set '" + set + "' twice");
    TracedModel::ContactSet cs{set, {}};
    std::string rest = entry.substr(eq + 1);
    if (rest.empty())
      throw TracerError("CONTACTS: the set '" + set + "' is empty; name its frames" + usage);
    for (std::size_t from = 0; from <= rest.size();) {
      const std::size_t end = std::min(rest.find(',', from), rest.size());
      const std::string piece = rest.substr(from, end - from);
      std::string frame = piece;
      from = end + 1;
      bool six_d = false;
      if (frame.ends_with(":6d")) {
        six_d = true;
        frame.resize(frame.size() - 3);
      }
      if (frame.empty() || frame.find(':') != std::string::npos)
        throw TracerError("CONTACTS: the set '" + set + "' has a malformed entry '" + piece + "'" + usage);
      const int f = frame_index("CONTACTS (set '" + set + "')", frame, frame_names);
      auto at = std::find(r.frames.begin(), r.frames.end(), f);
      if (at == r.frames.end()) at = r.frames.insert(r.frames.end(), f);
      const int k = static_cast<int>(at - r.frames.begin());
      for (const auto& c : cs.contacts)
        if (c.frame == k)
          throw TracerError("CONTACTS: the set '" + set + "' names the frame '" + frame + "' twice; a frame "
                            "is one contact (mark it :6d to hold its orientation too)");
      cs.contacts.push_back({k, six_d});
    }
    r.contact_sets.push_back(std::move(cs));
  }
  for (const std::string& k : o.kernels)
    if (const auto id = kernel_from_name(k); id && of_mass_centre(*id)) r.mass_centre = true;
  return r;
}

int generate(const TracerOptions& o, TracedModel& m) {
  // Requestable: the default kernels, then those generated only when named (eomgen/kernels.hpp).
  const std::vector<KernelId> applicable = requestable_kernels(m);
  if (o.list_kernels) {
    for (KernelId k : applicable) std::cout << signature(k).name << '\n';
    return 0;
  }
  std::vector<KernelId> kernels;
  for (const std::string& name : o.kernels) {
    if (name == "defaults") {  // the kernels generated without KERNELS, then the ones named
      for (KernelId k : applicable_kernels(m))
        if (std::find(kernels.begin(), kernels.end(), k) == kernels.end()) kernels.push_back(k);
      continue;
    }
    const auto k = kernel_from_name(name);
    if (!k) {
      std::vector<std::string_view> names{"defaults"};
      for (int i = 0; i < kernel_count; ++i) names.push_back(signature(static_cast<KernelId>(i)).name);
      throw TracerError("unknown kernel '" + name + "'" + did_you_mean(name, names) +
                        " (valid kernels: " + valid_kernel_names() +
                        "; or defaults: every kernel generated without KERNELS)");
    }
    if (std::find(applicable.begin(), applicable.end(), *k) == applicable.end())
      throw TracerError("kernel " + name + " requested, but " +
                        (per_frame(*k)           ? std::string("FRAMES names no frame")
                         : per_contact_set(*k)   ? std::string("CONTACTS names no contact set")
                         : of_mass_centre(*k)    ? std::string("the model has no bodies (it states T itself)")
                                                 : std::string("the model has no constraints")));
    if (std::find(kernels.begin(), kernels.end(), *k) == kernels.end()) kernels.push_back(*k);
  }
  if (o.kernels.empty()) kernels = applicable_kernels(m);

  const std::vector<Kernel> built = build_kernels(m, kernels, o.solve);
  const EmittedFiles files = emit(m, built, o.ns, EmitOptions{o.batch_lanes});

  const std::filesystem::path dir(o.out_dir);
  std::filesystem::create_directories(dir);
  write_if_changed(dir / (o.name + ".hpp"), files.header);
  write_if_changed(dir / (o.name + ".cpp"), files.source);
  // A kernel this large takes a compiler tens of seconds and more as it grows (the looped
  // derivative kernels are O(nq³) statements, --solve unrolled makes any solve O(nq³) or more):
  // say so once, at generation, where the user can still leave it out, rather than leave a
  // silent long build.
  for (const auto& [k, ops] : files.operation_counts)
    if (long_compile(k, ops))
      std::cerr << "eomgen: " << o.label() << ": note: " << signature(k).name << " has " << ops
                << " operations, a long compile (130 000 take 24 s and 0.5 GB at -O2, and it grows "
                   "with size"
                << (k == KernelId::taylor_coefficients
                        ? "; here each weighs about " + std::to_string(taylor_compile_weight)
                        : std::string())
                << "); if the model does not need it, name the kernels it needs in KERNELS\n";
  return 0;
}

bool long_compile(KernelId k, std::size_t operations) {
  return operations * (k == KernelId::taylor_coefficients ? taylor_compile_weight : 1) > large_kernel_operations;
}

}  // namespace eom::gen
