// Pinocchio's CppADCodeGen output for eom_bench_pinocchio (bench/bench_pinocchio.cpp) and
// eom_bench_pinocchio_contacts, behind a small interface: the CodeGen templates take minutes to
// compile, so they live in their own translation unit (bench/pinocchio_codegen.cpp), compiled once.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <pinocchio/algorithm/contact-info.hpp>
#include <pinocchio/multibody/model.hpp>

namespace eombench {

// Rigid contacts (Pinocchio's RigidConstraintModel, which Pinocchio 3.7 marks deprecated: "the API
// will change"), as the constraint algorithms take them.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
using PinocchioContacts = std::vector<pinocchio::RigidConstraintModel,
                                      Eigen::aligned_allocator<pinocchio::RigidConstraintModel>>;
#pragma GCC diagnostic pop

// One generated Pinocchio algorithm, called through the raw C entry point of its library.
class PinocchioGenerated {
 public:
  enum class Algorithm {
    crba, rnea, aba, aba_derivatives, rnea_derivatives,
    constraint_dynamics, constraint_dynamics_derivatives  // these two take contacts
  };
  // Generates the C code of `algorithm` on `model` (Pinocchio's CodeGenCRBA, CodeGenRNEA,
  // CodeGenABA, CodeGenABADerivatives, CodeGenRNEADerivatives), compiles it with `compiler` at
  // -O3 -march=native into a library in the working directory (reused when it is there already:
  // its name has `name` and the model's name) and loads it. Throws std::runtime_error on failure.
  PinocchioGenerated(Algorithm algorithm, const pinocchio::Model& model, const std::string& name,
                     const std::string& compiler);
  // The same for the constraint algorithms on `contacts` (CodeGenConstraintDynamics,
  // CodeGenConstraintDynamicsDerivatives: constraintDynamics with Pinocchio's default
  // ProximalSettings, mu = 0, then for the second computeConstraintDynamicsDerivatives). Their
  // input is [q; v; τ].
  PinocchioGenerated(Algorithm algorithm, const pinocchio::Model& model,
                     const PinocchioContacts& contacts, const std::string& name,
                     const std::string& compiler);
  ~PinocchioGenerated();
  PinocchioGenerated(const PinocchioGenerated&) = delete;
  PinocchioGenerated& operator=(const PinocchioGenerated&) = delete;

  // x: the packed input ([q], [q; v; a] or [q; v; τ], as the CodeGen class packs it). The
  // outputs land in out(): crba M's upper triangle row by row; the derivative algorithms their
  // three n×n blocks row-major, one after the other; constraint_dynamics [v̇; λ];
  // constraint_dynamics_derivatives ∂v̇/∂q, ∂v̇/∂v, ∂v̇/∂τ (nv×nv, row-major), then ∂λ/∂q,
  // ∂λ/∂v, ∂λ/∂τ (nc×nv, column-major).
  void operator()(const double* x) {
    const double* in[1] = {x};
    double* out[1] = {out_.data()};
    fn_(in, out, Atomic{nullptr, nullptr, nullptr});
  }
  const double* out() const { return out_.data(); }

 private:
  // CppADCodeGen's model-library ABI: void <function>_forward_zero(in, out, LangCAtomicFun),
  // the struct passed by value.
  struct Atomic {
    void* model;
    int (*forward)(void*, int, int, int, int, const void*, void*);
    int (*reverse)(void*, int, int, int, const void*, void*, void*, void*);
  };
  using ForwardZero = void (*)(const double* const*, double* const*, Atomic);
  void load(const std::pair<std::string, long>& library, const std::string& name);
  void* handle_ = nullptr;
  ForwardZero fn_ = nullptr;
  std::vector<double> out_;
};

}  // namespace eombench
