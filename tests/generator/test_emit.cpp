// The emitted text (determinism, pruning, fixed parameters, kernel headers), the tracer's command
// line (files written only when changed, every error reported as one line and nothing written),
// and a 100-link chain through every graph pass.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <models/cartesian_pendulum.hpp>
#include <models/chain.hpp>
#include <models/spring_pendulum.hpp>
#include <eom/reference/reference.hpp>
#include <eomgen/emit.hpp>
#include <eomgen/optimize.hpp>
#include <eomgen/taylor.hpp>
#include <eomgen/tracer.hpp>

#include "chain_model.hpp"

namespace {

using namespace eom::gen;
using eom::models::CartesianPendulum;
using eom::models::SpringPendulum;
using eomtest::ChainModel;

EmittedFiles generate_spring(std::vector<KernelId> ks = {},
                             std::vector<std::optional<double>> fixed = {}) {
  TracedModel m = trace<SpringPendulum>("spring_pendulum", "eom::models::SpringPendulum", fixed);
  if (ks.empty()) ks = applicable_kernels(m);
  return emit(m, build_kernels(m, ks), "spring_pendulum");
}

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

TEST(Emit, IsDeterministic) {
  const EmittedFiles a = generate_spring(), b = generate_spring();
  EXPECT_EQ(a.header, b.header);
  EXPECT_EQ(a.source, b.source);
  TracedModel m = trace<CartesianPendulum>("cp", "CartesianPendulum");
  TracedModel n = trace<CartesianPendulum>("cp", "CartesianPendulum");
  EXPECT_EQ(emit(m, build_kernels(m, applicable_kernels(m)), "cp").source,
            emit(n, build_kernels(n, applicable_kernels(n)), "cp").source);
}

TEST(Emit, OnlyRequestedKernelsAppear) {
  const EmittedFiles f = generate_spring({KernelId::mass_matrix, KernelId::potential_energy});
  for (const std::string& text : {f.header, f.source}) {
    EXPECT_TRUE(contains(text, "mass_matrix("));
    EXPECT_TRUE(contains(text, "potential_energy("));
    for (const char* absent : {"coriolis", "forward_dynamics", "mass_matrix_dot", "kinetic_energy",
                               "inverse_dynamics", "potential_gradient", "pivot_ok"})
      EXPECT_FALSE(contains(text, absent)) << absent;
  }
  EXPECT_TRUE(contains(f.header, "static double potential_energy("));  // Kernels forwards it
}

TEST(Emit, FixedParametersAreFoldedAndRemovedFromP) {
  // Fix k = 75 and g = 9.5: p becomes (m, r0).
  const EmittedFiles f = generate_spring({KernelId::potential_gradient, KernelId::potential_energy},
                                         {std::nullopt, 75.0, std::nullopt, 9.5});
  EXPECT_TRUE(contains(f.header, "inline constexpr int np = 2;"));
  EXPECT_TRUE(contains(f.header, "parameter_names{\"m\", \"r0\"}"));
  EXPECT_TRUE(contains(f.header, "parameter_values{1.0, 0.5}"));
  EXPECT_FALSE(contains(f.source, "p[2]"));
  EXPECT_FALSE(contains(f.source, "p[3]"));
  EXPECT_TRUE(contains(f.source, "37.5")) << "½k folded";
  EXPECT_TRUE(contains(f.source, "9.5"));
}

TEST(Emit, EveryKernelOpensWithItsNameAndOperationCount) {
  const EmittedFiles f = generate_spring();
  ASSERT_EQ(f.operation_counts.size(), 11u);
  for (auto [k, ops] : f.operation_counts) {
    if (k == KernelId::taylor_coefficients) continue;  // its own head: TaylorKernel below
    const std::string head = "// spring_pendulum: " + std::string(signature(k).name) + " (" +
                             std::to_string(ops) + (ops == 1 ? " operation)\n" : " operations)\n");
    EXPECT_TRUE(contains(f.source, head)) << head;
  }
  // One statement per operation: the statements of a kernel number its operations.
  const std::regex kernel(R"(// spring_pendulum: (\w+) \((\d+) operations?\)\n([^]*?)\n\}\n)");
  int seen = 0;
  for (std::sregex_iterator it(f.source.begin(), f.source.end(), kernel), end; it != end; ++it) {
    const std::string body = (*it)[3];
    // (the arguments' test is no operation; consecutive finiteness guards share one test, each
    // guard a nonfinite_carry)
    const std::regex statement(
        R"(  const (double|bool) v\d+ = |  if \(!(pivot_ok|is_finite)\([^|\n]*\) return fail|nonfinite_carry\()");
    const auto count = std::distance(std::sregex_iterator(body.begin(), body.end(), statement),
                                     std::sregex_iterator());
    EXPECT_EQ(std::to_string(count), (*it)[2].str()) << (*it)[1];
    ++seen;
  }
  // the 10 kernels and, for those that read values of p alone, <kernel>_prepare (those values)
  const std::regex prepare(R"(// spring_pendulum: \w+_prepare \()");
  const auto prepares = std::distance(std::sregex_iterator(f.source.begin(), f.source.end(), prepare),
                                      std::sregex_iterator());
  EXPECT_EQ(seen, 10 + prepares);
}

// A kernel caches its parameter-only values only when they cost more than the cache's check
// (16 + np/4 operations): the spring pendulum's coriolis reads one product of p (2·m) and
// computes it inline; the 5-link chain's forward dynamics has 67 such operations and caches them.
TEST(Emit, ParameterCacheOnlyWhereItPays) {
  TracedModel spring = trace<SpringPendulum>("sp", "SpringPendulum");
  const EmittedFiles small = emit(spring, build_kernels(spring, std::vector{KernelId::coriolis}), "sp");
  EXPECT_EQ(small.source.find("_prepare"), std::string::npos);
  EXPECT_EQ(small.source.find("pc["), std::string::npos);
  TracedModel chain = trace<eom::models::UndampedChain<5>>("c5", "eom::models::UndampedChain<5>");
  const EmittedFiles big = emit(chain, build_kernels(chain, std::vector{KernelId::forward_dynamics}), "c5");
  EXPECT_NE(big.source.find("forward_dynamics_prepare(const double* p, double* v)"), std::string::npos);
  EXPECT_NE(big.source.find("const double* const pc = forward_dynamics_parameters(p);"), std::string::npos);
}

// A kernel's count is its operations per call: the cone of its outputs and guards, except what
// depends on the parameters alone (real-valued: computed once per parameter set, read from the
// parameter cache).
TEST(Emit, CountsMatchTheGraph) {
  TracedModel m = trace<CartesianPendulum>("cp", "CartesianPendulum");
  const auto ks = build_kernels(m, applicable_kernels(m));
  const EmittedFiles f = emit(m, ks, "cp");
  const Graph& g = m.graph;
  for (std::size_t i = 0; i < ks.size(); ++i) {
    if (ks[i].id == KernelId::taylor_coefficients) continue;  // counted in TaylorKernel below
    std::vector<NodeId> stack = ks[i].outputs;
    stack.insert(stack.end(), ks[i].guards.begin(), ks[i].guards.end());
    // cached (a <kernel>_prepare exists): its parameter-only values are not counted per call
    const bool cached =
        f.source.find(std::string(signature(ks[i].id).name) + "_prepare(") != std::string::npos;
    std::vector<char> seen(g.size(), 0);
    std::size_t per_call = 0;
    while (!stack.empty()) {
      const NodeId n = stack.back();
      stack.pop_back();
      if (seen[n] || arity(g[n].op) == 0) continue;
      seen[n] = 1;
      if (cached && !is_boolean(g[n].op) && g.parameter_only(n)) continue;
      ++per_call;
      for (int a = 0; a < arity(g[n].op); ++a) stack.push_back(g[n].arg[a]);
    }
    EXPECT_EQ(f.operation_counts[i].second, per_call) << signature(ks[i].id).name;
  }
}

// The Taylor kernel: self-contained, its sizes in the header (namespace and Kernels), its head
// counting what the plan counts, one statement per counted operation.
TEST(Emit, TaylorKernel) {
  TracedModel m = trace<CartesianPendulum>("cp", "CartesianPendulum");
  const auto ks = build_kernels(m, std::vector<KernelId>{KernelId::taylor_coefficients});
  const EmittedFiles f = emit(m, ks, "cp");
  const TaylorPlan plan = make_taylor_plan(m.graph, *ks[0].system, ks[0].guards);
  for (const char* absent : {"forward_dynamics(", "mass_matrix(", "coriolis("})
    EXPECT_FALSE(contains(f.source, absent)) << absent;
  const std::regex sizes(R"(inline constexpr int taylor_workspace = (\d+);\ninline constexpr int taylor_max_order = (\d+);)");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(f.header, match, sizes)) << f.header;
  EXPECT_EQ(std::stoul(match[1]), plan.slots);
  EXPECT_EQ(std::stoi(match[2]), taylor_max_order);
  EXPECT_TRUE(contains(f.header, "static constexpr int taylor_workspace = ::cp::taylor_workspace;"));
  EXPECT_TRUE(contains(f.header, "static bool taylor_coefficients(int order, double t"));
  const std::regex head(R"(// cp: taylor_coefficients \((\d+) operations at order 0; per coefficient (\d+) series, (\d+) by recurrence, (\d+) convolution tails?, (\d+) solve steps?; (\d+) stored series\)\n)");
  ASSERT_TRUE(std::regex_search(f.source, match, head));
  EXPECT_EQ(std::stoul(match[2]), plan.series);
  EXPECT_EQ(std::stoul(match[3]), plan.recurrences);
  EXPECT_EQ(std::stoul(match[4]), plan.tails);
  EXPECT_EQ(std::stoul(match[5]), plan.solve_nodes.size());
  EXPECT_EQ(std::stoul(match[6]), plan.slots);
  // Per coefficient one statement per series node, right-hand side row, solve step and result
  // (two lines for a q̈: the series and the output); the constraint's M is constant here.
  const std::string loop = f.source.substr(f.source.find("for (int k = 1; k < order; ++k)"));
  const std::regex statement(R"(\n    (const double [yb]\d+|s\w+\[k\]|qdk\[\(k) )");
  const auto statements =
      std::distance(std::sregex_iterator(loop.begin(), loop.end(), statement), std::sregex_iterator());
  std::size_t stored_inputs = 0;  // copied into their series first
  for (NodeId n : plan.nodes) stored_inputs += m.graph[n].op == Op::Input && plan.stored[n];
  EXPECT_EQ(static_cast<std::size_t>(statements),
            stored_inputs + plan.series + (m.nq + m.nc) + plan.solve_nodes.size() + 2 * m.nq + m.nc)
      << loop;
  EXPECT_EQ(f.operation_counts.at(0).second,
            std::stoul(match[1]) + plan.series + plan.tails + plan.solve_nodes.size());
}

// ---- the tracer's command line ----

struct TracerRun : ::testing::Test {
  std::filesystem::path dir = std::filesystem::temp_directory_path() /
                              ("eomgen_test_" + std::to_string(::getpid()) + "_" +
                               ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::string err, out;
  void SetUp() override { std::filesystem::remove_all(dir); }
  void TearDown() override { std::filesystem::remove_all(dir); }

  template <class Model> int run(std::vector<std::string> args) {
    args.insert(args.begin(), "tracer");
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    ::testing::internal::CaptureStderr();
    ::testing::internal::CaptureStdout();
    const int rc = tracer_main<Model>(static_cast<int>(argv.size()), argv.data());
    out = ::testing::internal::GetCapturedStdout();
    err = ::testing::internal::GetCapturedStderr();
    // Under AddressSanitizer (scripts/sanitize.sh) the first stack switch of eom::Reference's
    // heap stack prints ASan's one-time notice on swapcontext: not the tracer's output.
    err = std::regex_replace(err, std::regex("==[0-9]+==WARNING: ASan doesn't fully support "
                                             "makecontext/swapcontext[^\n]*\n"), "");
    return rc;
  }
  std::vector<std::string> base(const std::string& name, const std::string& cls) {
    return {"--name", name, "--class", cls, "--out-dir", dir.string()};
  }
  std::vector<std::string> spring(std::vector<std::string> extra = {}) {
    auto a = base("spring_pendulum", "eom::models::SpringPendulum");
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }
  bool nothing_written() const { return !std::filesystem::exists(dir) || std::filesystem::is_empty(dir); }
};

TEST_F(TracerRun, WritesBothFilesOnlyWhenChanged) {
  ASSERT_EQ(run<SpringPendulum>(spring({"--namespace", "gen::sp"})), 0) << err;
  const auto hpp = dir / "spring_pendulum.hpp", cpp = dir / "spring_pendulum.cpp";
  ASSERT_TRUE(std::filesystem::exists(hpp));
  ASSERT_TRUE(std::filesystem::exists(cpp));
  EXPECT_TRUE(err.empty()) << err;
  const auto t_hpp = std::filesystem::last_write_time(hpp);
  std::filesystem::last_write_time(cpp, t_hpp - std::chrono::hours(1));
  const auto t_cpp = std::filesystem::last_write_time(cpp);
  ASSERT_EQ(run<SpringPendulum>(spring({"--namespace", "gen::sp"})), 0) << err;
  EXPECT_EQ(std::filesystem::last_write_time(hpp), t_hpp) << "unchanged: not rewritten";
  EXPECT_EQ(std::filesystem::last_write_time(cpp), t_cpp);
  ASSERT_EQ(run<SpringPendulum>(spring({"--namespace", "gen::sp", "--kernel", "mass_matrix"})), 0);
  EXPECT_NE(std::filesystem::last_write_time(cpp), t_cpp) << "changed: rewritten";
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().extension() == ".tmp", false) << "no temporary left: " << e.path();
}

TEST_F(TracerRun, ListsKernels) {
  ASSERT_EQ(run<SpringPendulum>({"--name", "sp", "--class", "SP", "--list-kernels"}), 0);
  EXPECT_TRUE(contains(out, "mass_matrix\n"));
  EXPECT_FALSE(contains(out, "constraint_jacobian"));
  EXPECT_TRUE(contains(out, "forward_dynamics_parameter_derivatives\n")) << "on request, listed";
  ASSERT_EQ(run<CartesianPendulum>({"--list-kernels"}), 0);
  EXPECT_TRUE(contains(out, "constraint_jacobian\n"));
}

// forward_dynamics_parameter_derivatives only when asked for: the default set leaves it out.
TEST_F(TracerRun, ParameterDerivativesOnlyOnRequest) {
  ASSERT_EQ(run<SpringPendulum>(spring({})), 0) << err;
  std::ifstream in(dir / "spring_pendulum.hpp");
  const std::string header((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(contains(header, "forward_dynamics_derivatives("));
  EXPECT_FALSE(contains(header, "forward_dynamics_parameter_derivatives"));
  ASSERT_EQ(run<SpringPendulum>(
                spring({"--kernel", "forward_dynamics_parameter_derivatives"})), 0) << err;
  std::ifstream again(dir / "spring_pendulum.hpp");
  const std::string asked((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(contains(asked, "bool forward_dynamics_parameter_derivatives(double t"));
  EXPECT_TRUE(contains(asked, "double* dqdd_dp"));
}

void expect_error(const std::string& err, const std::string& label, const std::string& what) {
  EXPECT_EQ(err.rfind("eomgen: " + label + ": ", 0), 0u) << err;
  EXPECT_TRUE(contains(err, what)) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "one line: " << err;
}

// forward_dynamics_batch only when asked for; `defaults` keeps the default set beside it.
// A kernel a compiler needs minutes for is named at generation (a note; the files are written).
TEST_F(TracerRun, NotesAKernelThatWillCompileForLong) {
  auto args = base("chain30", "ChainModel<30>");
  args.insert(args.end(), {"--kernel", "forward_dynamics", "--kernel", "forward_dynamics_derivatives"});
  // Unrolled, the derivatives' 60 solves are 130 426 operations; looped (the default at 30
  // coordinates) only their right-hand sides are statements.
  ASSERT_EQ(run<ChainModel<30>>(args), 0) << err;
  EXPECT_EQ(err, "");
  args.insert(args.end(), {"--solve", "unrolled"});
  ASSERT_EQ(run<ChainModel<30>>(args), 0) << err;
  EXPECT_TRUE(std::filesystem::exists(dir / "chain30.cpp"));
  EXPECT_TRUE(contains(err, "eomgen: model chain30 (ChainModel<30>): note: forward_dynamics_derivatives has "))
      << err;
  EXPECT_FALSE(contains(err, "note: forward_dynamics has")) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  ASSERT_EQ(run<SpringPendulum>(spring()), 0);
  EXPECT_EQ(err, "");
}

// The Taylor kernel's operations weigh more: 20 801 of them at 50 links compile for 38 s.
TEST_F(TracerRun, NotesATaylorKernelThatWillCompileForLong) {
  EXPECT_FALSE(long_compile(KernelId::taylor_coefficients, large_kernel_operations / taylor_compile_weight));
  EXPECT_TRUE(long_compile(KernelId::taylor_coefficients, large_kernel_operations / taylor_compile_weight + 1));
  EXPECT_FALSE(long_compile(KernelId::forward_dynamics, large_kernel_operations));
  auto args = base("chain30", "ChainModel<30>");
  args.insert(args.end(), {"--kernel", "taylor_coefficients"});
  ASSERT_EQ(run<ChainModel<30>>(args), 0) << err;
  EXPECT_EQ(err, "");
  args = base("chain50", "ChainModel<50>");
  args.insert(args.end(), {"--kernel", "taylor_coefficients"});
  ASSERT_EQ(run<ChainModel<50>>(args), 0) << err;
  EXPECT_TRUE(contains(err, "eomgen: model chain50 (ChainModel<50>): note: taylor_coefficients has ")) << err;
  EXPECT_TRUE(contains(err, "here each weighs about " + std::to_string(taylor_compile_weight))) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
}

TEST_F(TracerRun, BatchKernelOnRequest) {
  auto header = [&] {
    std::ifstream in(dir / "spring_pendulum.hpp");
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  ASSERT_EQ(run<SpringPendulum>(spring({})), 0) << err;
  EXPECT_FALSE(contains(header(), "batch"));
  ASSERT_EQ(run<SpringPendulum>(spring({"--kernel", "defaults", "--kernel",
                                        "forward_dynamics_batch", "--batch-lanes", "8"})),
            0)
      << err;
  const std::string h = header();
  EXPECT_TRUE(contains(h, "void mass_matrix(")) << "defaults kept";
  EXPECT_TRUE(contains(h, "bool taylor_coefficients("));
  EXPECT_FALSE(contains(h, "forward_dynamics_parameter_derivatives")) << "on request only";
  EXPECT_TRUE(contains(h, "inline constexpr int batch_lanes = 8;"));
  EXPECT_TRUE(contains(h, "unsigned forward_dynamics_batch(const double* t, const double* q"));
  EXPECT_TRUE(contains(h, "static constexpr int batch_lanes = ::spring_pendulum::batch_lanes;"));
}

TEST_F(TracerRun, RejectsABadLaneCount) {
  EXPECT_EQ(
      run<SpringPendulum>(spring({"--kernel", "forward_dynamics_batch", "--batch-lanes", "3"})), 1);
  expect_error(err, "model spring_pendulum (eom::models::SpringPendulum)",
               "--batch-lanes takes 2, 4 or 8, not 3");
  EXPECT_TRUE(nothing_written());
}

// The batch kernel is written in the unrolled form only: where the solve is looped (a chain from
// looped_solve_from coordinates on, or when asked for), only when the unrolled form is asked for.
TEST(EmitBatch, BigModelsNeedTheUnrolledFormAskedFor) {
  TracedModel m = trace<ChainModel<looped_solve_from>>("chain30", "ChainModel<30>");
  const KernelId batch[] = {KernelId::forward_dynamics_batch};
  try {
    build_kernels(m, batch);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "model chain30 (ChainModel<30>): forward_dynamics_batch is "
                                   "written in the unrolled form only, and the solve here is looped "
                                   "(M's factor has 435 entries below the diagonal: from 435 on (a "
                                   "full M of 30 coordinates)"))
        << e.what();
  }
  const auto ks = build_kernels(m, batch, SolveForm::unrolled);
  EXPECT_THROW(emit(m, ks, "c", EmitOptions{3}), std::invalid_argument);
  EXPECT_TRUE(contains(emit(m, ks, "c").source, "unsigned forward_dynamics_batch("));
}

// N pendulums side by side: M is diagonal and its factor has no entry below the diagonal, so the
// automatic form stays unrolled however many coordinates (the rule counts L's fill, not nq).
template <int N> struct PendulumRow : ChainModel<N> {
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    S T = 0.0;
    for (int i = 0; i < N; ++i) T += 0.5 * p[0] * p[1] * p[1] * qd[i] * qd[i];
    return T;
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::sin;
    S V = 0.0;
    for (int i = 0; i < N; ++i) V += p[0] * p[2] * p[1] * sin(q[i]);
    return V;
  }
};

TEST(EmitBatch, ASparseMassMatrixKeepsTheUnrolledForm) {
  TracedModel row = trace<PendulumRow<32>>("row32", "PendulumRow<32>");
  const KernelId both[] = {KernelId::forward_dynamics, KernelId::forward_dynamics_batch};
  const auto ks = build_kernels(row, both);  // no error: the batch kernel needs the unrolled form
  ASSERT_EQ(ks.size(), 2u);
  EXPECT_FALSE(ks[0].looped);
  EXPECT_TRUE(contains(emit(row, ks, "c").source, "unsigned forward_dynamics_batch("));
  TracedModel chain = trace<ChainModel<32>>("chain32", "ChainModel<32>");  // M full: 496 entries
  const KernelId fd[] = {KernelId::forward_dynamics};
  EXPECT_TRUE(build_kernels(chain, fd)[0].looped);
}

TEST(EmitBatch, AskingForTheLoopedFormExcludesTheBatchKernel) {
  TracedModel m = trace<ChainModel<3>>("chain3", "ChainModel<3>");
  const KernelId batch[] = {KernelId::forward_dynamics_batch};
  EXPECT_TRUE(contains(emit(m, build_kernels(m, batch), "c").source, "unsigned forward_dynamics_batch("));
  try {
    build_kernels(m, batch, SolveForm::looped);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "model chain3 (ChainModel<3>): forward_dynamics_batch is "
                                   "written in the unrolled form only, and the solve here is "
                                   "looped (--solve looped was asked for"))
        << e.what();
  }
}

// The one rule for the solve's form, as the two tests above and the looped kernels rely on it.
static_assert(solve_form(looped_fill_from - 1, SolveForm::automatic) == SolveForm::unrolled);
static_assert(solve_form(looped_fill_from, SolveForm::automatic) == SolveForm::looped);
static_assert(looped_fill_from == 435);  // a full M of 30 coordinates
static_assert(solve_form(2, SolveForm::looped) == SolveForm::looped);
static_assert(solve_form(100, SolveForm::unrolled) == SolveForm::unrolled);
// And the contact derivative kernels' (by their directions).
static_assert(contact_solve_form(contact_rows_from - 1, SolveForm::automatic) == SolveForm::unrolled);
static_assert(contact_solve_form(contact_rows_from, SolveForm::automatic) == SolveForm::looped);
static_assert(contact_solve_form(100, SolveForm::unrolled) == SolveForm::unrolled);
static_assert(contact_solve_form(2, SolveForm::looped) == SolveForm::looped);

TEST_F(TracerRun, RejectsBadArguments) {
  const std::string label = "model spring_pendulum (eom::models::SpringPendulum)";
  EXPECT_EQ(run<SpringPendulum>(spring({"--kernel", "mass_matrx"})), 1);
  expect_error(err, label, "unknown kernel 'mass_matrx'; did you mean 'mass_matrix'? (valid kernels: "
                           "mass_matrix, mass_matrix_dot");
  EXPECT_EQ(run<SpringPendulum>(spring({"--kernel", "constraint_jacobian"})), 1);
  expect_error(err, label, "no constraints");
  EXPECT_EQ(run<SpringPendulum>(spring({"--fixed", "kk=3"})), 1);
  expect_error(err, label, "unknown parameter 'kk'; did you mean 'k'? (the model's parameters: m, k, "
                           "r0, g)");
  EXPECT_EQ(run<SpringPendulum>(spring({"--fixed", "k"})), 1);
  expect_error(err, label, "malformed");
  EXPECT_EQ(run<SpringPendulum>(spring({"--fixed", "k=7x"})), 1);
  expect_error(err, label, "not a number");
  EXPECT_EQ(run<SpringPendulum>(spring({"--fixed", "k=inf"})), 1);
  expect_error(err, label, "finite");
  EXPECT_EQ(run<SpringPendulum>(spring({"--namespace", "not a namespace"})), 1);
  expect_error(err, label, "namespace");
  EXPECT_TRUE(nothing_written());
}

struct Branching {
  static constexpr std::array coordinates{"x"};
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) { return 0.5 * qd[0] * qd[0]; }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) {
    if (q[0] > 0) return q[0];  // must be eom::select
    return -q[0];
  }
};
struct ThrowsWhenTraced {
  static constexpr std::array coordinates{"x"};
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) { return 0.5 * qd[0] * qd[0]; }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) { return q[0]; }
  template <class S>
  static void generalized_forces(const S&, eom::In<S>, eom::In<S>, eom::In<S>, eom::In<S>, eom::Out<S> Q) {
    if constexpr (std::is_same_v<S, Expr>) throw std::runtime_error("boom");
    Q[0] = 0.0;
  }
};
struct NotFinite {
  static constexpr std::array coordinates{"x", "y"};
  static constexpr std::array constraint_names{"c"};
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) { return 0.5 * qd[0] * qd[0] + 0.5 * qd[1] * qd[1]; }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) { return q[0]; }
  template <class S> static void constraints(eom::In<S> q, eom::In<S>, eom::Out<S> phi) {
    using std::log;
    phi[0] = log(q[0] - 1.0);  // q[0] = 0.4 at the check point
  }
};

TEST_F(TracerRun, RejectsBadModels) {
  EXPECT_EQ(run<Branching>(base("branching", "Branching")), 1);
  expect_error(err, "model branching (Branching)", "potential_energy branches on a traced value");
  EXPECT_TRUE(contains(err, "eom::select"));
  EXPECT_EQ(run<ThrowsWhenTraced>(base("throws", "ThrowsWhenTraced")), 1);
  expect_error(err, "model throws (ThrowsWhenTraced)", "generalized_forces threw while being traced: boom");
  EXPECT_EQ(run<NotFinite>(base("nan", "NotFinite")), 1);
  expect_error(err, "model nan (NotFinite)", "constraints is not finite");
  EXPECT_TRUE(nothing_written());
}

// ---- scale: a 100-link planar chain (absolute angles), every pass iterative ----

TEST(Scale, ChainAgreesWithReference) {
  using Model = ChainModel<8>;
  TracedModel m = trace<Model>("chain8", "ChainModel<8>");
  const auto kernels = build_kernels(m, std::vector<KernelId>{KernelId::forward_dynamics});
  Point x;
  for (int i = 0; i < 8; ++i) {
    x.q.push_back(0.3 * std::sin(0.7 * i));
    x.qd.push_back(0.2 * std::cos(1.3 * i));
  }
  x.p = {0.01, 0.5, 9.81};
  std::vector<double> ref(8);
  ASSERT_TRUE(eom::Reference<Model>::forward_dynamics(0, x.q.data(), x.qd.data(), nullptr,
                                                      x.p.data(), ref.data()));
  const auto got = evaluate(m.graph, kernels[0].outputs, x);
  double err = 0, scale = 1;
  for (int i = 0; i < 8; ++i) {
    err = std::max(err, std::abs(got[i] - ref[i]));
    scale = std::max(scale, std::abs(ref[i]));
  }
  EXPECT_LE(err / scale, 1e-12);
}

TEST(Scale, HundredLinkChain) {
  using Model = ChainModel<100>;
  const auto start = std::chrono::steady_clock::now();
  TracedModel m = trace<Model>("chain100", "ChainModel<100>");
  const std::vector<KernelId> ks{KernelId::mass_matrix, KernelId::coriolis,
                                 KernelId::potential_gradient, KernelId::forward_dynamics,
                                 KernelId::inverse_dynamics};
  const auto kernels = build_kernels(m, ks);
  const EmittedFiles f = emit(m, kernels, "chain100");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::size_t ops = 0;
  for (auto [k, n] : f.operation_counts) {
    std::printf("  chain100 %-20s %zu operations\n", std::string(signature(k).name).c_str(), n);
    ops += n;
  }
  const auto lines = std::count(f.source.begin(), f.source.end(), '\n');
  std::printf("  chain100: %zu nodes, %zu operations, %ld source lines, %.2f s\n", m.graph.size(),
              ops, static_cast<long>(lines), seconds);
  // Emitted size stays near the operation count: one line per operation plus the outputs.
  EXPECT_LT(static_cast<std::size_t>(lines), ops + 3 * 100 * 100 + 1000);
  // From looped_solve_from coordinates on, forward_dynamics loops over its factorization.
  EXPECT_NE(f.source.find("solve_dense_system<100, 0>(system, qdd)"), std::string::npos);
  // Physics: the extra force needed for the q̈ of the forward dynamics is zero.
  Point x;
  for (int i = 0; i < 100; ++i) {
    x.q.push_back(0.3 * std::sin(0.7 * i));
    x.qd.push_back(0.2 * std::cos(1.3 * i));
  }
  x.p = {0.01, 0.5, 9.81};
  // Looped, forward_dynamics is its linear system only; the evaluator solves it by the dense
  // routine (taylor_ode's coefficient 1 of q̇ is q̈).
  ASSERT_TRUE(kernels[3].looped);
  EXPECT_TRUE(kernels[3].outputs.empty() && kernels[3].guards.empty());
  const auto series = taylor_ode(m.graph, *kernels[3].system, x, 1);
  x.qdd.assign(series[1].begin() + 100, series[1].begin() + 200);
  const auto tau = evaluate(m.graph, kernels[4].outputs, x);
  const auto dV = evaluate(m.graph, kernels[2].outputs, x);
  double err = 0, scale = 0;
  for (int i = 0; i < 100; ++i) {
    err = std::max(err, std::abs(tau[i]));
    scale = std::max(scale, std::abs(dV[i]));
  }
  std::printf("  chain100: max |tau(forward_dynamics)| / max |dV/dq| = %.3g\n", err / scale);
  EXPECT_LE(err / scale, 1e-8);
}

// Taylor mode at scale: per coefficient, the series of M, f (O(n²) for a chain whose M is dense)
// and the convolution tails (one per entry of M that moves: n² − n, the diagonal being constant
// once collected, sin² + cos² = 1), never the O(n³) factorization; the emitted
// size stays near the operation count; taylor_ode's order 1 is the forward dynamics, in the
// unrolled form and in the looped one (the default at this size, which drops the order-0
// factorization too).
TEST(Scale, HundredLinkChainTaylor) {
  using Model = ChainModel<100>;
  constexpr int n = 100;
  TracedModel m = trace<Model>("chain100", "ChainModel<100>");
  const std::vector<KernelId> taylor{KernelId::taylor_coefficients};
  const auto kernels = build_kernels(m, taylor, SolveForm::unrolled);
  const Kernel& k = kernels.at(0);
  const TaylorPlan system = make_taylor_plan(m.graph, *k.system, k.guards);
  const TaylorPlan through = make_taylor_plan(m.graph, k.outputs, k.guards);  // plain mode
  std::printf("  chain100 taylor: per coefficient %zu recurrences + %zu tails (through the "
              "factorization: %zu recurrences)\n",
              system.recurrences, system.tails, through.recurrences);
  EXPECT_EQ(system.tails, std::size_t(n) * (n - 1));
  EXPECT_LT(system.recurrences + system.tails, through.recurrences / 5);
  const EmittedFiles f = emit(m, kernels, "chain100");
  // One line per operation, plus each part's series pointers (measured: 1.13 lines per operation).
  const double lines = static_cast<double>(std::count(f.source.begin(), f.source.end(), '\n'));
  std::printf("  chain100 taylor: %.0f lines for %zu operations\n", lines, f.operation_counts.at(0).second);
  EXPECT_LT(lines, 1.25 * static_cast<double>(f.operation_counts.at(0).second));

  Point x;
  for (int i = 0; i < n; ++i) {
    x.q.push_back(0.3 * std::sin(0.7 * i));
    x.qd.push_back(0.2 * std::cos(1.3 * i));
  }
  x.p = {0.01, 0.5, 9.81};
  const auto qdd = evaluate(m.graph, k.outputs, x);
  const auto series = taylor_ode(m.graph, *k.system, x, 3);
  for (int i = 0; i < n; ++i) EXPECT_EQ(series[1][n + i], qdd[i]);

  const auto looped = build_kernels(m, taylor);
  ASSERT_TRUE(looped.at(0).looped);
  const EmittedFiles g = emit(m, looped, "chain100");
  std::printf("  chain100 taylor: %zu operations unrolled, %zu looped\n", f.operation_counts.at(0).second,
              g.operation_counts.at(0).second);
  EXPECT_LT(3 * g.operation_counts.at(0).second, f.operation_counts.at(0).second);
  EXPECT_NE(g.source.find("solve_dense_columns<100, 0>(dense, dense + "), std::string::npos);
  // The evaluator runs the looped form too (the dense routine at run-time sizes): the same q̈.
  const auto looped_series = taylor_ode(m.graph, *looped.at(0).system, x, 3);
  double scale = 0;
  for (int i = 0; i < n; ++i) scale = std::max(scale, std::abs(qdd[i]));
  for (int i = 0; i < n; ++i) EXPECT_NEAR(looped_series[1][n + i], qdd[i], 1e-12 * scale) << i;
}

}  // namespace
