// Physical consistency of a body-form model's bodies, evaluated in double: the generator checks
// them at the default parameters before tracing (a build error naming the model and body), and
// eom::Reference checks them on every call in builds without NDEBUG (a message and abort, like
// assert). A body passes when
//   - its mass is finite and ≥ 0,
//   - its inertia is finite and physically realizable: positive semidefinite principal moments
//     λ that satisfy the triangle inequality λ₁ ≤ λ₂ + λ₃ (zero moments are allowed: a point mass,
//     a slender rod),
//   - (spatial) its rotation is orthonormal, max |RᵀR − 1| ≤ 1e-9, with det R = +1,
// the inertia tolerances relative to the largest moment, 1e-9.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <type_traits>
#include <vector>

#include "eom/model/model.hpp"

namespace eom {

namespace detail {

inline std::string format_number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", x);
  return buffer;
}

// Eigenvalues of the symmetric 3×3 matrix [[a b c] [b d e] [c e f]], ascending (closed form).
inline std::array<double, 3> symmetric_eigenvalues(double a, double d, double f, double b, double c,
                                                   double e) {
  const double off = b * b + c * c + e * e, mean = (a + d + f) / 3.0;
  const double spread2 = (a - mean) * (a - mean) + (d - mean) * (d - mean) +
                         (f - mean) * (f - mean) + 2.0 * off;
  if (spread2 == 0.0) return {mean, mean, mean};
  const double s = std::sqrt(spread2 / 6.0);
  // B = (A − mean·1)/s; det(B)/2 = cos(3φ).
  const double ba = (a - mean) / s, bd = (d - mean) / s, bf = (f - mean) / s;
  const double bb = b / s, bc = c / s, be = e / s;
  const double det = ba * (bd * bf - be * be) - bb * (bb * bf - be * bc) + bc * (bb * be - bd * bc);
  const double phi = std::acos(std::clamp(det / 2.0, -1.0, 1.0)) / 3.0;
  const double largest = mean + 2.0 * s * std::cos(phi);
  const double smallest = mean + 2.0 * s * std::cos(phi + 2.0 * std::numbers::pi / 3.0);
  return {smallest, 3.0 * mean - largest - smallest, largest};
}

// Whether the symmetric 3×3 matrix [[a b c] [b d e] [c e f]] is positive semidefinite up to
// tol·scaleᵏ for its k×k principal minors: all seven principal minors ≥ 0 (not just the leading
// ones, which would pass diag(0, 0, −1)). Unlike the closed-form eigenvalues above, which lose
// half the digits at a double eigenvalue (a slender rod's (0, I, I) came out (0, I − 3e-9 I,
// I + 3e-9 I)), the minors of an exactly singular PSD matrix stay exact or within rounding.
inline bool positive_semidefinite(double a, double d, double f, double b, double c, double e,
                                  double scale, double tol) {
  const double t1 = tol * scale, t2 = t1 * scale, t3 = t2 * scale;
  const double det = a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c);
  return a >= -t1 && d >= -t1 && f >= -t1 && a * d - b * b >= -t2 && a * f - c * c >= -t2 &&
         d * f - e * e >= -t2 && det >= -t3;
}

inline bool all_finite(std::initializer_list<double> xs) {
  return std::all_of(xs.begin(), xs.end(), [](double x) { return std::isfinite(x); });
}

}  // namespace detail

// What is wrong with a rotation matrix ("" when nothing is): `axes` names what it turns into what.
inline std::string rotation_problem(const std::array<double, 9>& R, const std::string& axes) {
  double worst = 0;  // max |RᵀR − 1|
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double dot = R[3 * i] * R[3 * j] + R[3 * i + 1] * R[3 * j + 1] + R[3 * i + 2] * R[3 * j + 2];
      worst = std::max(worst, std::abs(dot - (i == j ? 1.0 : 0.0)));
    }
  if (worst > 1e-9)
    return "rotation is not orthonormal: max |R^T R - 1| = " + detail::format_number(worst) +
           " > 1e-9 (rotation is the " + axes + " matrix, column-major)";
  const double det = R[0] * (R[4] * R[8] - R[7] * R[5]) - R[3] * (R[1] * R[8] - R[7] * R[2]) +
                     R[6] * (R[1] * R[5] - R[4] * R[2]);
  if (det < 0) return "rotation is a reflection (det R = -1), not a rotation";
  return "";
}

// What is wrong with one body ("" when nothing is).
inline std::string body_problem(const PlanarBody<double>& b) {
  if (!detail::all_finite({b.mass, b.inertia, b.x, b.y, b.angle}))
    return "a mass, inertia, position or angle is not finite (NaN or Inf)";
  if (b.mass < 0) return "negative mass " + detail::format_number(b.mass);
  if (b.inertia < 0) return "negative inertia " + detail::format_number(b.inertia);
  return "";
}

// check_inertia = false skips the last two (a model that declares
// `static constexpr bool inconsistent_inertia_accepted = true`, e.g. eomgen-urdf --inertia warn).
inline std::string body_problem(const SpatialBody<double>& b, bool check_inertia = true) {
  const auto& J = b.inertia;
  const auto& R = b.rotation;
  if (!detail::all_finite({b.mass, J[0], J[1], J[2], J[3], J[4], J[5]}))
    return "its mass or inertia is not finite (NaN or Inf)";
  if (!detail::all_finite({b.position[0], b.position[1], b.position[2], R[0], R[1], R[2], R[3],
                           R[4], R[5], R[6], R[7], R[8]}))
    return "its position or rotation is not finite (NaN or Inf)";
  if (b.mass < 0) return "negative mass " + detail::format_number(b.mass);

  if (std::string problem = rotation_problem(R, "body-to-world"); !problem.empty()) return problem;
  if (!check_inertia) return "";

  const auto moments = detail::symmetric_eigenvalues(J[0], J[1], J[2], J[3], J[4], J[5]);
  const double scale = std::max({std::abs(moments[0]), std::abs(moments[2]), 1e-300});
  const std::string listed = " (principal moments " + detail::format_number(moments[0]) + ", " +
                             detail::format_number(moments[1]) + ", " +
                             detail::format_number(moments[2]) + ")";
  // J ⪰ 0; the triangle inequality λ3 ≤ λ1 + λ2 (λ3 the largest) is λ3 ≤ tr(J)/2, i.e.
  // ½tr(J)·1 − J ⪰ 0. Both tested by minors; the moments only size the tolerance and the message.
  if (!detail::positive_semidefinite(J[0], J[1], J[2], J[3], J[4], J[5], scale, 1e-9))
    return "inertia tensor is not positive definite" + listed;
  const double half_trace = 0.5 * (J[0] + J[1] + J[2]);
  if (!detail::positive_semidefinite(half_trace - J[0], half_trace - J[1], half_trace - J[2], -J[3],
                                     -J[4], -J[5], scale, 1e-9))
    return "inertia tensor violates the triangle inequality, largest moment > sum of the other "
           "two" + listed;
  return "";
}

// The first problem with a body-form model's bodies at (q, p): "body <i>: <problem>", or "" when
// they are all consistent (or the model states T itself).
template <class Model>
std::string body_problem(std::span<const double> q, std::span<const double> p) {
  if constexpr (detail::declares_bodies<Model>) {
    std::vector<BodyOf<Model, double>> bodies(Model::body_count);
    Model::template bodies<double>(q, p, bodies);
    constexpr bool accepted = [] {
      if constexpr (requires { Model::inconsistent_inertia_accepted; })
        return static_cast<bool>(Model::inconsistent_inertia_accepted);
      return false;
    }();
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      std::string problem;
      if constexpr (std::is_same_v<BodyOf<Model, double>, SpatialBody<double>>)
        problem = body_problem(bodies[i], !accepted);
      else
        problem = body_problem(bodies[i]);
      if (!problem.empty()) return "body " + std::to_string(i) + ": " + problem;
    }
  }
  return "";
}

}  // namespace eom
