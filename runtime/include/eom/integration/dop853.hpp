// Dormand–Prince 8(5,3): Hairer's DOP853 (Hairer, Nørsett & Wanner, Solving ODEs I, §II.10 and
// the DOP853 code), the explicit Runge–Kutta method of order 8 with 12 stages, over any
// eom::Dynamics. The 8th-order solution is propagated; its 13th evaluation, f at the new
// solution, is the next step's first (FSAL), so an accepted step costs 12 evaluations of
// forward_dynamics and a rejected one 11.
//
// Error control: two embedded estimates, e₅ (the difference to a 5th-order solution) and e₃ (to a
// 3rd-order one), combined as err = ‖e₅‖² / sqrt(‖e₅‖² + 0.01·‖e₃‖²) in the norm
// ‖e‖ = sqrt(mean((eᵢ / (atol + rtol·max(|xᵢ|, |x̃ᵢ|)))²)). This behaves like h⁸ for small
// steps (‖e₅‖ ~ h⁶, ‖e₃‖ ~ h⁴) and like ‖e₅‖ when the 3rd-order estimate is not larger, so it
// is neither as optimistic as e₅ alone at large steps nor as pessimistic as e₃. A step is
// accepted when err ≤ 1; the next is h·min(6, max(1/3, 0.9·err^(−1/8))), and not larger than
// the current one right after a rejection.
//
// Dense output (AdaptiveOptions::output_times): the continuous extension of order 7 (local
// error O(h⁸)), which needs three more stages; they are evaluated only for steps that contain a
// requested time. A step whose FSAL or dense-output stages fail (singular or non-finite dynamics)
// is rejected and retried smaller, like one whose error is too large. Allocation-free; never
// hangs (step limit), never returns NaN silently (status).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "eom/integration/explicit_rk.hpp"

namespace eom {

namespace detail {
// The DOP853 coefficients as published by Hairer (dop853.f, 30 digits); stage j is k[j − 1].
// Stages 1–12 make the step, stage 13 is f at the new solution (its row is b), stages 14–16
// serve only the dense output. Checked against all 200 order conditions of order ≤ 8 in
// tests/runtime/test_dop853.cpp.
struct Dop853Tableau {
  static constexpr std::array<double, 16> c{
      0,
      0.526001519587677318785587544488e-01,  // (6 − √6)/30 · 4/9
      0.789002279381515978178381316732e-01,  // (6 − √6)/30 · 2/3
      0.118350341907227396726757197510,      // (6 − √6)/30
      0.281649658092772603273242802490,      // (6 + √6)/30
      1.0 / 3,
      0.25,
      4.0 / 13,
      127.0 / 195,
      0.6,
      6.0 / 7,
      1,
      1,
      0.1,
      0.2,
      7.0 / 9};
  static constexpr std::array<std::array<double, 16>, 16> a{{
      {},
      {5.26001519587677318785587544488e-2},
      {1.97250569845378994544595329183e-2, 5.91751709536136983633785987549e-2},
      {2.95875854768068491816892993775e-2, 0, 8.87627564304205475450678981324e-2},
      {2.41365134159266685502369798665e-1, 0, -8.84549479328286085344864962717e-1,
       9.24834003261792003115737966543e-1},
      {3.7037037037037037037037037037e-2, 0, 0, 1.70828608729473871279604482173e-1,
       1.25467687566822425016691814123e-1},
      {3.7109375e-2, 0, 0, 1.70252211019544039314978060272e-1, 6.02165389804559606850219397283e-2,
       -1.7578125e-2},
      {3.70920001185047927108779319836e-2, 0, 0, 1.70383925712239993810214054705e-1,
       1.07262030446373284651809199168e-1, -1.53194377486244017527936158236e-2,
       8.27378916381402288758473766002e-3},
      {6.24110958716075717114429577812e-1, 0, 0, -3.36089262944694129406857109825,
       -8.68219346841726006818189891453e-1, 2.75920996994467083049415600797e1,
       2.01540675504778934086186788979e1, -4.34898841810699588477366255144e1},
      {4.77662536438264365890433908527e-1, 0, 0, -2.48811461997166764192642586468,
       -5.90290826836842996371446475743e-1, 2.12300514481811942347288949897e1,
       1.52792336328824235832596922938e1, -3.32882109689848629194453265587e1,
       -2.03312017085086261358222928593e-2},
      {-9.3714243008598732571704021658e-1, 0, 0, 5.18637242884406370830023853209,
       1.09143734899672957818500254654, -8.14978701074692612513997267357,
       -1.85200656599969598641566180701e1, 2.27394870993505042818970056734e1,
       2.49360555267965238987089396762, -3.0467644718982195003823669022},
      {2.27331014751653820792359768449, 0, 0, -1.05344954667372501984066689879e1,
       -2.00087205822486249909675718444, -1.79589318631187989172765950534e1,
       2.79488845294199600508499808837e1, -2.85899827713502369474065508674,
       -8.87285693353062954433549289258, 1.23605671757943030647266201528e1,
       6.43392746015763530355970484046e-1},
      // stage 13 = f(t + h, x_new): its row is the 8th-order weights b
      {5.42937341165687622380535766363e-2, 0, 0, 0, 0, 4.45031289275240888144113950566,
       1.89151789931450038304281599044, -5.8012039600105847814672114227,
       3.1116436695781989440891606237e-1, -1.52160949662516078556178806805e-1,
       2.01365400804030348374776537501e-1, 4.47106157277725905176885569043e-2},
      {5.61675022830479523392909219681e-2, 0, 0, 0, 0, 0, 2.53500210216624811088794765333e-1,
       -2.46239037470802489917441475441e-1, -1.24191423263816360469010140626e-1,
       1.5329179827876569731206322685e-1, 8.20105229563468988491666602057e-3,
       7.56789766054569976138603589584e-3, -8.298e-3},
      {3.18346481635021405060768473261e-2, 0, 0, 0, 0, 2.83009096723667755288322961402e-2,
       5.35419883074385676223797384372e-2, -5.49237485713909884646569340306e-2, 0, 0,
       -1.08347328697249322858509316994e-4, 3.82571090835658412954920192323e-4,
       -3.40465008687404560802977114492e-4, 1.41312443674632500278074618366e-1},
      {-4.28896301583791923408573538692e-1, 0, 0, 0, 0, -4.69762141536116384314449447206,
       7.68342119606259904184240953878, 4.06898981839711007970213554331,
       3.56727187455281109270669543021e-1, 0, 0, 0, -1.39902416515901462129418009734e-3,
       2.9475147891527723389556272149, -9.15095847217987001081870187138},
  }};
  static constexpr const std::array<double, 16>& b = a[12];  // 8th order
  // b − b̂ for the embedded 5th-order weights b̂ (Hairer's er1…er12)
  static constexpr std::array<double, 12> e5{
      0.1312004499419488073250102996e-01, 0, 0, 0, 0, -0.1225156446376204440720569753e+01,
      -0.4957589496572501915214079952, 0.1664377182454986536961530415e+01,
      -0.3503288487499736816886487290, 0.3341791187130174790297318841,
      0.8192320648511571246570742613e-01, -0.2235530786388629525884427845e-01};
  // The embedded 3rd-order weights (Hairer's bhh1…bhh3, on stages 1, 9 and 12) and b − them
  static constexpr std::array<double, 12> b3{
      0.244094488188976377952755905512, 0, 0, 0, 0, 0, 0, 0,
      0.733846688281611857341361741547, 0, 0, 0.220588235294117647058823529412e-01};
  static constexpr std::array<double, 12> e3 = [] {
    std::array<double, 12> diff{};
    for (std::size_t j = 0; j < diff.size(); ++j) diff[j] = b[j] - b3[j];
    return diff;
  }();
  // The continuous extension's coefficients 5–8 (Hairer's d4…, d5…, d6…, d7… rows)
  static constexpr std::array<std::array<double, 16>, 4> d{{
      {-0.84289382761090128651353491142e+01, 0, 0, 0, 0, 0.56671495351937776962531783590e+00,
       -0.30689499459498916912797304727e+01, 0.23846676565120698287728149680e+01,
       0.21170345824450282767155149946e+01, -0.87139158377797299206789907490e+00,
       0.22404374302607882758541771650e+01, 0.63157877876946881815570249290e+00,
       -0.88990336451333310820698117400e-01, 0.18148505520854727256656404962e+02,
       -0.91946323924783554000451984436e+01, -0.44360363875948939664310572000e+01},
      {0.10427508642579134603413151009e+02, 0, 0, 0, 0, 0.24228349177525818288430175319e+03,
       0.16520045171727028198505394887e+03, -0.37454675472269020279518312152e+03,
       -0.22113666853125306036270938578e+02, 0.77334326684722638389603898808e+01,
       -0.30674084731089398182061213626e+02, -0.93321305264302278729567221706e+01,
       0.15697238121770843886131091075e+02, -0.31139403219565177677282850411e+02,
       -0.93529243588444783865713862664e+01, 0.35816841486394083752465898540e+02},
      {0.19985053242002433820987653617e+02, 0, 0, 0, 0, -0.38703730874935176555105901742e+03,
       -0.18917813819516756882830838328e+03, 0.52780815920542364900561016686e+03,
       -0.11573902539959630126141871134e+02, 0.68812326946963000169666922661e+01,
       -0.10006050966910838403183860980e+01, 0.77771377980534432092869265740e+00,
       -0.27782057523535084065932004339e+01, -0.60196695231264120758267380846e+02,
       0.84320405506677161018159903784e+02, 0.11992291136182789328035130030e+02},
      {-0.25693933462703749003312586129e+02, 0, 0, 0, 0, -0.15418974869023643374053993627e+03,
       -0.23152937917604549567536039109e+03, 0.35763911791061412378285349910e+03,
       0.93405324183624310003907691704e+02, -0.37458323136451633156875139351e+02,
       0.10409964950896230045147246184e+03, 0.29840293426660503123344363579e+02,
       -0.43533456590011143754432175058e+02, 0.96324553959188282948394950600e+02,
       -0.39177261675615439165231486172e+02, -0.14972683625798562581422125276e+03},
  }};
};

// One DOP853 step, its error and its dense output, over any f(t, x, ẋ) → bool on fixed-size
// states.
template <std::size_t m> struct Dop853Step {
  using Vec = std::array<double, m>;
  static constexpr int order = 8;
  static constexpr std::size_t fsal = 12;
  static constexpr double exponent = -0.125, min_factor = 1.0 / 3, max_factor = 6.0;
  static constexpr bool cap_after_rejection = true;  // as Hairer's DOP853 code

  std::array<Vec, 16> k;   // k[0] = f(t, x) on entry; stages 2–12, 13 (FSAL), 14–16 (dense)
  Vec x_new, error5, error3;
  std::array<Vec, 8> dense;

  // Stages 2–12 of the step from (t, x) of size h, the 8th-order solution and both error
  // estimates; the combined error norm, ∞ when f fails.
  template <class F>
  double attempt(F&& f, double t, double h, const Vec& x, const AdaptiveOptions& opt) noexcept {
    using T = Dop853Tableau;
    Vec y;
    bool ok = true;
    [&]<std::size_t... s>(std::index_sequence<s...>) {
      ((ok = ok && (advance<T::a[s + 1]>(x, h, k, y), f(t + T::c[s + 1] * h, y, k[s + 1]))), ...);
    }(std::make_index_sequence<11>{});
    if (!ok) return std::numeric_limits<double>::infinity();
    advance<T::b>(x, h, k, x_new);
    scaled_sum<T::e5>(h, k, error5);
    scaled_sum<T::e3>(h, k, error3);
    return error(x, opt);
  }

  // An acceptable step still needs its FSAL stage and, for dense output, stages 14–16.
  template <class F> bool complete(F&& f, double t, double h, const Vec& x, bool dense_output) noexcept {
    return finish(f, t, h) && (!dense_output || prepare_dense(f, t, h, x));
  }

  // The combined error ‖e₅‖² / sqrt(‖e₅‖² + 0.01·‖e₃‖²) of the attempted step from x (hypot
  // keeps it from overflowing; both estimates zero means no error, NaN stays NaN).
  double error(const Vec& x, const AdaptiveOptions& opt) const noexcept {
    const double e5 = error_norm(error5, x, x_new, opt), e3 = error_norm(error3, x, x_new, opt);
    const double scale = std::hypot(e5, 0.1 * e3);
    return scale > 0 ? e5 * (e5 / scale) : scale;
  }

  // Stage 13, f(t + h, x_new): the next step's first; false when f fails or is not finite.
  template <class F> bool finish(F&& f, double t, double h) noexcept {
    return f(t + h, x_new, k[12]) && all_finite(k[12]);
  }

  // Stages 14–16 and the coefficients of the continuous extension of the finished step from
  // (t, x); false when f fails or is not finite.
  template <class F> bool prepare_dense(F&& f, double t, double h, const Vec& x) noexcept {
    using T = Dop853Tableau;
    Vec y;
    bool ok = true;
    [&]<std::size_t... s>(std::index_sequence<s...>) {
      ((ok = ok && (advance<T::a[s + 13]>(x, h, k, y), f(t + T::c[s + 13] * h, y, k[s + 13])) &&
             all_finite(k[s + 13])),
       ...);
    }(std::make_index_sequence<3>{});
    if (!ok) return false;
    for (std::size_t i = 0; i < m; ++i) {
      dense[0][i] = x[i];
      dense[1][i] = x_new[i] - x[i];
      dense[2][i] = h * k[0][i] - dense[1][i];
      dense[3][i] = dense[1][i] - h * k[12][i] - dense[2][i];
    }
    scaled_sum<T::d[0]>(h, k, dense[4]);
    scaled_sum<T::d[1]>(h, k, dense[5]);
    scaled_sum<T::d[2]>(h, k, dense[6]);
    scaled_sum<T::d[3]>(h, k, dense[7]);
    return true;
  }

  // The state at t + θh, θ ∈ [0, 1]: r₁ + θ(r₂ + (1−θ)(r₃ + θ(r₄ + (1−θ)(r₅ + θ(r₆ + (1−θ)(r₇ + θ r₈)))))).
  void interpolate(double theta, Vec& out) const noexcept {
    const double rest = 1 - theta;
    for (std::size_t i = 0; i < m; ++i) {
      double v = dense[6][i] + theta * dense[7][i];
      v = dense[5][i] + rest * v;
      v = dense[4][i] + theta * v;
      v = dense[3][i] + rest * v;
      v = dense[2][i] + theta * v;
      v = dense[1][i] + rest * v;
      out[i] = dense[0][i] + theta * v;
    }
  }
};
}  // namespace detail

// Integrates from t0 to t1, calling observer(t, x) at t0 and after every accepted step, or with
// opt.output_times at exactly those times (dense output). Same options, result and
// stabilization (constrained models) as dopri5; with projection, every dense-output state is
// projected too, and a free joint's quaternion normalized (state.hpp).
template <Dynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> dop853(double t0, double t1, const StateFor<K>& x0,
                                       const double* u, const double* p,
                                       const AdaptiveOptions& opt, Observer&& observer,
                                       const Stabilization& stab = {}) noexcept {
  return detail::explicit_rk<detail::Dop853Step, K>(t0, t1, x0, u, p, opt,
                                                    std::forward<Observer>(observer), stab);
}

}  // namespace eom
