// The work-precision study's reference trajectories (bench/work_precision_reference.cpp): the
// state at t1 from (0, x0) with parameters p, computed in a wider type.
#pragma once

#include <vector>

// stiff_spring_pendulum is the spring pendulum in long double: the explicit extrapolation needs
// ~1e5 steps on it (stability, not accuracy), too many for double-double.
enum class ReferenceModel { spring_pendulum, stiff_spring_pendulum, double_pendulum, chain10, closed_chain5 };

// self_difference receives max |x(tol) − x(1e4 tol)|, a bound on the reference's own error.
std::vector<double> reference_state(ReferenceModel model, const std::vector<double>& x0,
                                    const std::vector<double>& p, double t1, double* self_difference);
