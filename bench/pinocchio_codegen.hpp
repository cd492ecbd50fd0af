// Pinocchio's CppADCodeGen output for eom_bench_pinocchio (bench/bench_pinocchio.cpp), behind a
// small interface: the CodeGen templates take minutes to compile, so they live in their own
// translation unit (bench/pinocchio_codegen.cpp), compiled once.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <pinocchio/multibody/model.hpp>

namespace eombench {

// One generated Pinocchio algorithm, called through the raw C entry point of its library.
class PinocchioGenerated {
 public:
  enum class Algorithm { crba, rnea, aba, aba_derivatives, rnea_derivatives };
  // Generates the C code of `algorithm` on `model` (Pinocchio's CodeGenCRBA, CodeGenRNEA,
  // CodeGenABA, CodeGenABADerivatives, CodeGenRNEADerivatives), compiles it with `compiler` at
  // -O3 -march=native into a library in the working directory (reused when it is there already:
  // its name has `name` and the model's name) and loads it. Throws std::runtime_error on failure.
  PinocchioGenerated(Algorithm algorithm, const pinocchio::Model& model, const std::string& name,
                     const std::string& compiler);
  ~PinocchioGenerated();
  PinocchioGenerated(const PinocchioGenerated&) = delete;
  PinocchioGenerated& operator=(const PinocchioGenerated&) = delete;

  // x: the packed input ([q], [q; v; a] or [q; v; τ], as the CodeGen class packs it). The
  // outputs land in out(): crba M's upper triangle row by row; the derivative algorithms their
  // three n×n blocks row-major, one after the other.
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
  void* handle_ = nullptr;
  ForwardZero fn_ = nullptr;
  std::vector<double> out_;
};

}  // namespace eombench
