// The tracer: the one program add_eom_model() builds per model, as
//
//   #include "<model header>"
//   #include <eomgen/tracer.hpp>
//   int main(int argc, char** argv) { return eom::gen::tracer_main<CLASS>(argc, argv); }
//
// and runs at build time:
//
//   <tracer> --name <name> --class <C++ class> --namespace <ns> --out-dir <dir>
//            [--kernel <k>]... [--fixed <param>=<value> | ALL]... [--free <param>]...
//            [--frame <frame>]... [--contact <set>=<frame>[:6d][,...]]... [--list-kernels]
//            [--solve unrolled|looped|automatic]   (the solve's form, eomgen/kernels.hpp)
//            [--batch-lanes 2|4|8]                 (forward_dynamics_batch, default 4)
//
// It checks the model (in double, at its default parameters, at a generic point), traces it,
// derives the requested kernels (default: every one that applies, except those generated only on
// request, like forward_dynamics_parameter_derivatives; the --kernel `defaults` stands for that
// default set, so `--kernel defaults --kernel forward_dynamics_batch` adds one), and writes
// <dir>/<name>.hpp
// and <dir>/<name>.cpp, each only when its content changed and by rename, so a build stays
// incremental and never sees a half-written file. Any problem is one line on stderr,
// `eomgen: model <name> (<class>): <problem>`, exit code 1, and nothing is written. A kernel of
// more than large_kernel_operations operations gets a `note:` line on stderr (exit code 0).
#pragma once

#include <array>
#include <cmath>
#include <exception>
#include <iostream>
#include <optional>
#include <sstream>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <eom/model/model.hpp>
#include <eom/multibody/body_check.hpp>
#include <eom/multibody/frames.hpp>
#include <eom/numeric/linalg.hpp>
#include <eom/reference/reference.hpp>

#include "eomgen/emit.hpp"
#include "eomgen/trace.hpp"

namespace eom::gen {

// Operations from which a kernel's compile takes long enough to be worth a note (the 30-link
// chain's forward_dynamics_derivatives, 130 000 operations, takes 24 s and 0.5 GB at -O2).
inline constexpr std::size_t large_kernel_operations = 100000;
// An operation of taylor_coefficients costs the compiler about as much as this many of another
// kernel (its per-coefficient statements are calls inside the loop over k). At -O2: the Panda's
// Taylor kernel, 15 467 operations, 14 s; the UR5's, 12 899, 11 s; the 50-link chain's, 20 801,
// 38 s (5 to 10 times the derivatives' time per operation): the chain's gets the note, the arms'
// not.
inline constexpr std::size_t taylor_compile_weight = 6;

// Whether kernel k of `operations` operations is worth the note.
bool long_compile(KernelId k, std::size_t operations);

struct TracerOptions {
  std::string name = "?", class_name = "?", ns, out_dir;
  std::vector<std::string> kernels;
  std::vector<std::string> fixed;  // "<param>=<value>" or "ALL" (every parameter at its default)
  std::vector<std::string> free;   // with ALL: the parameters that stay free (FREE_PARAMETERS)
  std::vector<std::string> frames;  // --frame (FRAMES): the frames to generate code for
  // --contact (CONTACTS): "<set>=<frame>[:6d][,<frame>[:6d]...]", one per contact set
  std::vector<std::string> contacts;
  bool list_kernels = false;
  SolveForm solve = SolveForm::automatic;  // --solve unrolled|looped (for measurements; kernels.hpp)
  int batch_lanes = default_batch_lanes;  // --batch-lanes 2|4|8 (forward_dynamics_batch)

  std::string label() const { return "model " + name + " (" + class_name + ")"; }
};

// A problem with the arguments or the model, reported as `eomgen: <label>: <what>`.
class TracerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Each throws TracerError. Options are filled as they are read, so an error names the model.
void parse_tracer_arguments(int argc, char** argv, TracerOptions& o);
// fixed[i] for each model parameter i, from the --fixed arguments: ALL fixes every parameter at
// its default (`defaults`), but those named by --free; <param>=<value> fixes one at that value.
std::vector<std::optional<double>> resolve_fixed(const TracerOptions& o,
                                                 std::span<const std::string_view> parameters,
                                                 std::span<const double> defaults);
// What to trace beyond the energies: the --frame names resolved into the model's frame_names,
// the --contact sets (their frames join the frames if not named there), and the mass centre when
// a --kernel asks for it.
TraceRequest trace_request(const TracerOptions& o, std::span<const std::string_view> frame_names);
// "; did you mean 'x'?" (or "'x' or 'y'") for the valid names closest to a misspelt one, by edit
// distance; "" when none is close.
std::string did_you_mean(std::string_view name, std::span<const std::string_view> valid);
// Derives, emits and writes the files (or lists the kernels); returns the exit code.
int generate(const TracerOptions& o, TracedModel& m);

// The generic point at which a model is checked in double.
inline double check_point(InputKind k, int i) {
  switch (k) {
    case InputKind::q: return 0.4 + 0.13 * i;
    case InputKind::qd: return 0.3 - 0.07 * i;
    case InputKind::u: return 0.2 + 0.05 * i;
    default: return 0.25;
  }
}

// The name of velocity j: its coordinate's, or with a free joint (nv = nq − 1) the linear
// velocity's (the position coordinates' names), the angular velocity's, or a joint's.
template <class Model> std::string velocity_name(int j) {
  if constexpr (ModelInfo<Model>::floating_base) {
    if (j >= 3 && j < 6)
      return std::string("angular velocity ") + "xyz"[j - 3] + " of the free joint";
    return std::string(Model::coordinates[j < 3 ? j : j + 1]);
  } else {
    return std::string(Model::coordinates[j]);
  }
}

// M (eom::Reference, exact AD) at (q, p) must pass the forward dynamics' pivot test: a model whose
// kinetic energy is not positive definite (a sign error, a negative mass, a coordinate nothing
// moves) has no forward dynamics, so the build stops naming the coordinate of the first pivot that
// fails (factored in the order of the coordinates), whether M is indefinite or singular.
template <class Model> void check_mass_matrix(const std::vector<double>& q, const std::vector<double>& p) {
  constexpr int nv = ModelInfo<Model>::nv;
  std::array<double, nv * nv> M;
  eom::Reference<Model>::mass_matrix(q.data(), p.empty() ? nullptr : p.data(), M.data());
  const auto failure = eom::linalg::first_failing_pivot<nv>(M);
  if (failure.problem == eom::linalg::PivotProblem::none) return;
  using eom::linalg::PivotProblem;
  const char* what = failure.problem == PivotProblem::indefinite ? "negative: M is indefinite"
                     : failure.problem == PivotProblem::singular ? "zero to rounding: M is singular"
                                                                 : "not finite";
  std::ostringstream m;
  m.precision(6);
  m << "kinetic energy is not positive definite: M's pivot for coordinate '"
    << velocity_name<Model>(failure.index) << "' (velocity " << failure.index << ") is "
    << failure.pivot << " (" << what << "; its diagonal entry " << failure.diagonal
    << "), at the default parameters at a generic point (q_i = 0.4 + 0.13 i); check the signs, "
       "masses and inertias in "
    << (eom::detail::declares_bodies<Model> ? "bodies()" : "kinetic_energy()")
    << ": T must be positive for every nonzero velocity";
  throw TracerError(m.str());
}

// Evaluates each model function in double at check_point, at the default parameters with the
// fixed ones applied; throws TracerError naming the first function that is not finite there.
template <class Model>
void check_model(std::span<const std::optional<double>> fixed) {
  using Info = ModelInfo<Model>;
  std::vector<double> q, qd, u, p;
  for (int i = 0; i < Info::nq; ++i) q.push_back(check_point(InputKind::q, i));
  eom::normalize_configuration(Info::layout, q.data());  // the free and ball joints' quaternions
  for (int i = 0; i < Info::nv; ++i) qd.push_back(check_point(InputKind::qd, i));
  for (int i = 0; i < Info::nu; ++i) u.push_back(check_point(InputKind::u, i));
  const auto defaults = Info::default_parameters();
  for (int i = 0; i < Info::np; ++i)
    p.push_back(i < static_cast<int>(fixed.size()) && fixed[i] ? *fixed[i] : defaults[i]);
  const double t = check_point(InputKind::t, 0);

  auto check = [&](std::string_view function, auto&& body) {
    std::vector<double> values;
    try {
      values = body();
    } catch (const std::exception& e) {
      throw TracerError(std::string(function) + " threw when evaluated in double: " + e.what());
    }
    for (double v : values)
      if (!std::isfinite(v))
        throw TracerError(std::string(function) +
                          " is not finite (NaN or Inf) in double at the default parameters at a "
                          "generic point (q_i = 0.4 + 0.13 i, a free joint's quaternion "
                          "normalized, qd_i = 0.3 - 0.07 i, u_i = 0.2 + 0.05 i, t = 0.25)");
  };
  check(eom::detail::declares_bodies<Model> ? "bodies" : "kinetic_energy", [&] {
    return std::vector<double>{eom::kinetic_energy_of<Model, double>(q, qd, p)};
  });
  if (const std::string problem = eom::body_problem<Model>(q, p); !problem.empty())
    throw TracerError("bodies: " + problem +
                      ", at the default parameters at a generic point (q_i = 0.4 + 0.13 i)");
  check_mass_matrix<Model>(q, p);
  if (const std::string problem = eom::frame_problem<Model>(q, p); !problem.empty())
    throw TracerError((eom::detail::declares_frames<Model> ? "frames: " : "link_frames: ") + problem +
                      ", at the default parameters at a generic point (q_i = 0.4 + 0.13 i)");
  check("potential_energy", [&] {
    return std::vector<double>{Model::template potential_energy<double>(q, p)};
  });
  if constexpr (Info::nc > 0)
    check("constraints", [&] {
      std::vector<double> phi(Info::nc);
      Model::template constraints<double>(q, p, phi);
      return phi;
    });
  if constexpr (Info::has_generalized_forces)
    check("generalized_forces", [&] {
      std::vector<double> Q(Info::nv);
      Model::template generalized_forces<double>(t, q, qd, u, p, Q);
      return Q;
    });
}

template <class Model>
int tracer_main(int argc, char** argv) {
  TracerOptions o;
  try {
    parse_tracer_arguments(argc, argv, o);
    std::vector<std::string_view> parameters;
    if constexpr (ModelInfo<Model>::np > 0)
      for (const auto& n : Model::parameters) parameters.emplace_back(n);
    const auto defaults = ModelInfo<Model>::default_parameters();
    const auto fixed = resolve_fixed(o, parameters, defaults);
    check_model<Model>(fixed);
    const auto& frames = ModelInfo<Model>::frame_names;
    TracedModel m = trace<Model>(o.name, o.class_name, fixed,
                                 trace_request(o, std::span<const std::string_view>(frames)));
    return generate(o, m);
  } catch (const TraceError& e) {  // its message names the model and function already
    std::cerr << "eomgen: " << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << "eomgen: " << o.label() << ": " << e.what() << '\n';
  }
  return 1;
}

}  // namespace eom::gen
