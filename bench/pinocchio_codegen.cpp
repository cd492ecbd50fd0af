// Pinocchio's CodeGen classes for eom_bench_pinocchio: see pinocchio_codegen.hpp.
#include <pinocchio/codegen/cppadcg.hpp>  // first: Pinocchio's CppADCodeGen scalar traits

#include <pinocchio/codegen/code-generator-algo.hpp>

#include <dlfcn.h>

#include <stdexcept>

#include "pinocchio_codegen.hpp"

namespace eombench {
namespace {

// Generates, compiles (unless the library is there) and names the library of one CodeGen class.
// Only the forward sweep is generated: Pinocchio's RNEA and ABA also emit a Jacobian by default,
// which is not timed. Pinocchio compiles with -Ofast by default; here the flags of eomgen's side.
// `extra`: what the class takes between the model and the names (the constraint classes' contacts).
template <class CodeGen> struct Build : CodeGen {
  template <class... Extra>
  Build(const pinocchio::Model& model, const std::string& name, const std::string& compiler,
        const Extra&... extra)
      : CodeGen(model, extra..., name, "pin_" + name) {
    this->build_jacobian = false;
    this->initLib();
    if (!this->existLib()) {
      CppAD::cg::GccCompiler<double> cc(compiler);
      cc.setCompileFlags({"-O3", "-march=native"});
      this->dynamicLibManager_ptr->createDynamicLibrary(cc, false);
    }
  }
  std::string file() const {
    return "./" + this->dynamicLibManager_ptr->getLibraryName() +
           CppAD::cg::system::SystemInfo<>::DYNAMIC_LIB_EXTENSION;
  }
  long outputs() const { return static_cast<long>(this->getOutputDimension()); }
};

template <class CodeGen, class... Extra>
std::pair<std::string, long> build(const pinocchio::Model& model, const std::string& name,
                                   const std::string& compiler, const Extra&... extra) {
  const Build<CodeGen> b(model, name, compiler, extra...);
  return {b.file(), b.outputs()};
}

}  // namespace

PinocchioGenerated::PinocchioGenerated(Algorithm algorithm, const pinocchio::Model& model,
                                       const std::string& name, const std::string& compiler) {
  std::pair<std::string, long> lib;
  switch (algorithm) {
    case Algorithm::crba: lib = build<pinocchio::CodeGenCRBA<double>>(model, name, compiler); break;
    case Algorithm::rnea: lib = build<pinocchio::CodeGenRNEA<double>>(model, name, compiler); break;
    case Algorithm::aba: lib = build<pinocchio::CodeGenABA<double>>(model, name, compiler); break;
    case Algorithm::aba_derivatives:
      lib = build<pinocchio::CodeGenABADerivatives<double>>(model, name, compiler);
      break;
    case Algorithm::rnea_derivatives:
      lib = build<pinocchio::CodeGenRNEADerivatives<double>>(model, name, compiler);
      break;
    case Algorithm::constraint_dynamics:
    case Algorithm::constraint_dynamics_derivatives:
      throw std::invalid_argument("PinocchioGenerated: the constraint algorithms take contacts");
  }
  load(lib, name);
}

PinocchioGenerated::PinocchioGenerated(Algorithm algorithm, const pinocchio::Model& model,
                                       const PinocchioContacts& contacts, const std::string& name,
                                       const std::string& compiler) {
  if (algorithm == Algorithm::constraint_dynamics)
    load(build<pinocchio::CodeGenConstraintDynamics<double>>(model, name, compiler, contacts), name);
  else if (algorithm == Algorithm::constraint_dynamics_derivatives)
    load(build<pinocchio::CodeGenConstraintDynamicsDerivatives<double>>(model, name, compiler,
                                                                         contacts),
         name);
  else
    throw std::invalid_argument("PinocchioGenerated: contacts given to an unconstrained algorithm");
}

void PinocchioGenerated::load(const std::pair<std::string, long>& lib, const std::string& name) {
  handle_ = dlopen(lib.first.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle_) throw std::runtime_error("dlopen " + lib.first + ": " + dlerror());
  const std::string symbol = name + "_forward_zero";
  fn_ = reinterpret_cast<ForwardZero>(dlsym(handle_, symbol.c_str()));
  if (!fn_) throw std::runtime_error(lib.first + ": no symbol " + symbol);
  out_.assign(static_cast<std::size_t>(lib.second), 0.0);
}

PinocchioGenerated::~PinocchioGenerated() { dlclose(handle_); }

}  // namespace eombench
