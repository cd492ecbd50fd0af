// The reference of eom_bench_pinocchio's accuracy table: Featherstone's algorithms in
// double-double (tests/support/recursive_dynamics.hpp) on the robot eomgen's URDF reader read,
// derivatives by central differences in double-double. In its own translation unit
// (bench/pinocchio_truth.cpp), compiled with -ffp-contract=off: qd's double-double arithmetic is
// wrong when the compiler contracts it into FMAs, as -march=native otherwise does.
#pragma once

#include <memory>
#include <vector>

#include <eomgen/urdf.hpp>

namespace eombench {

// One state's outputs in eomgen's conventions (τ = M q̈ + c + ∂V/∂q − (u − d⊙q̇); n×n column-major).
struct Truth {
  std::vector<double> M, qdd, tau, dqdd_dq, dqdd_dv, minv, dtau_dq, dtau_dv;
};

class PinocchioTruth {
 public:
  explicit PinocchioTruth(const eom::urdf::Robot& robot);
  ~PinocchioTruth();
  int nv() const;
  std::vector<double> damping() const;  // d of Q = u − d⊙q̇
  Truth at(const double* q, const double* v, const double* u, const double* a);

 private:
  struct Model;
  std::unique_ptr<Model> model_;
};

}  // namespace eombench
