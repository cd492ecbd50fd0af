// The taped run-time AD peer: ADOL-C (Debian's libadolc-dev) on a model's own templated source.
//
// A model is taped once, with its functions instantiated on adouble (the body form through
// eom::kinetic_energy_of, whose velocity pass nests eom::Embedded<1, adouble, 1>), its parameters
// recorded as ADOL-C tape parameters (mkparam) so that each call may change them
// (set_param_vec) without retaping. Two scalar tapes over x = (q, q̇):
//   T(q, q̇)        for mass_matrix and coriolis,
//   L = T − V       for forward_dynamics,
// plus, for constrained models, the tape of φ(q). Each kernel is then the fewest driver sweeps
// that give its result (the fastest honest use of ADOL-C's drivers we found):
//   M        one vector forward sweep with the nq directions (0, eⱼ), kept for one vector
//            second-order reverse sweep: the q̇ rows of ∇²T·(0, eⱼ) are M's columns
//            (hov_wk_forward + hos_ov_reverse, the body of ADOL-C's hess_mat driver without its
//            allocation per call).
//   c        one scalar forward sweep along (q̇, 0) and one second-order reverse sweep
//            (fos_forward + hos_reverse, the body of hess_vec): ∇T and ∇²T·(q̇, 0), whose q̇ rows
//            are Ṁq̇; c = Ṁq̇ − ∂T/∂q.
//   q̈        one vector sweep over L with the nq + 1 directions (q̇, 0), (0, eⱼ): ∂L/∂q, Ṁq̇
//            and M at once; f = Q − Ṁq̇ + ∂L/∂q with Q from the model in double. With
//            constraints, γ = Ċq̇ as twice the second Taylor coefficient of φ(q + q̇ s)
//            (hos_forward, d = 2) and C by one vector reverse sweep over that forward sweep
//            (fov_reverse, nc unit weights). Then the same numerical solve as eom::Reference
//            (eom::linalg::solve_constrained).
#pragma once

#include <adolc/adolc.h>

#include <array>
#include <cstddef>
#include <limits>
#include <vector>

#include <eom/model/model.hpp>
#include <eom/numeric/linalg.hpp>

namespace eom_bench {

template <class Model> class AdolcPeer {
 public:
  using Info = eom::ModelInfo<Model>;
  static constexpr int nq = Info::nq, np = Info::np, nu = Info::nu, nc = Info::nc;

  // Tapes the model at (q, q̇, p) under the tags first_tag, first_tag + 1, first_tag + 2.
  AdolcPeer(short first_tag, const double* q, const double* qd, const double* p)
      : tag_T_(first_tag), tag_L_(first_tag + 1), tag_phi_(first_tag + 2) {
    record_energy(tag_T_, false, q, qd, p);
    record_energy(tag_L_, true, q, qd, p);
    if constexpr (nc > 0) record_constraints(q, p);

    // Driver workspaces, as the double** / double*** arrays ADOL-C's interface takes.
    constexpr int n = 2 * nq, dirs = nq + 1;
    X_ = matrix3(n, dirs, 1);
    Y_ = matrix3(1, dirs, 1);
    Z_ = matrix3(dirs, n, 2);
    U_ = matrix2(1, 2);
    U_[0][0] = 1.0;
    U_[0][1] = 0.0;
    Zvec_ = matrix2(n, 2);
    if constexpr (nc > 0) {
      Uc_ = matrix2(nc, nc);
      for (int k = 0; k < nc; ++k)
        for (int j = 0; j < nc; ++j) Uc_[k][j] = k == j ? 1.0 : 0.0;
      Cz_ = matrix2(nc, nq);
      Xt_ = matrix2(nq, 2);
      Yt_ = matrix2(nc, 2);
    }
  }
  AdolcPeer(const AdolcPeer&) = delete;
  AdolcPeer& operator=(const AdolcPeer&) = delete;
  ~AdolcPeer() {
    myfree3(X_);
    myfree3(Y_);
    myfree3(Z_);
    myfree2(U_);
    myfree2(Zvec_);
    if constexpr (nc > 0) {
      myfree2(Uc_);
      myfree2(Cz_);
      myfree2(Xt_);
      myfree2(Yt_);
    }
  }

  void mass_matrix(const double* q, const double* p, double* M) {
    set_param_vec(tag_T_, np, const_cast<double*>(p));
    std::array<double, 2 * nq> x{};
    for (int i = 0; i < nq; ++i) x[i] = q[i];  // q̇ = 0: M does not depend on it
    for (int d = 0; d < nq; ++d)
      for (int i = 0; i < 2 * nq; ++i) X_[i][d][0] = i == nq + d ? 1.0 : 0.0;
    double y;
    hov_wk_forward(tag_T_, 1, 2 * nq, 1, 2, nq, x.data(), X_, &y, Y_);
    hos_ov_reverse(tag_T_, 1, 2 * nq, 1, nq, U_, Z_);
    for (int j = 0; j < nq; ++j)
      for (int i = 0; i < nq; ++i) M[i + nq * j] = Z_[j][nq + i][1];
  }

  void coriolis(const double* q, const double* qd, const double* p, double* c) {
    set_param_vec(tag_T_, np, const_cast<double*>(p));
    std::array<double, 2 * nq> x, v{};
    for (int i = 0; i < nq; ++i) x[i] = q[i], x[nq + i] = qd[i], v[i] = qd[i];
    double y, ydot, u = 1.0;
    fos_forward(tag_T_, 1, 2 * nq, 2, x.data(), v.data(), &y, &ydot);
    hos_reverse(tag_T_, 1, 2 * nq, 1, &u, Zvec_);
    for (int i = 0; i < nq; ++i) c[i] = Zvec_[nq + i][1] - Zvec_[i][0];
  }

  bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                        const double* p, double* qdd) {
    set_param_vec(tag_L_, np, const_cast<double*>(p));
    std::array<double, 2 * nq> x;
    for (int i = 0; i < nq; ++i) x[i] = q[i], x[nq + i] = qd[i];
    // Direction 0: (q̇, 0); direction 1 + j: (0, eⱼ).
    for (int i = 0; i < 2 * nq; ++i) {
      X_[i][0][0] = i < nq ? qd[i] : 0.0;
      for (int d = 0; d < nq; ++d) X_[i][1 + d][0] = i == nq + d ? 1.0 : 0.0;
    }
    double y;
    hov_wk_forward(tag_L_, 1, 2 * nq, 1, 2, nq + 1, x.data(), X_, &y, Y_);
    hos_ov_reverse(tag_L_, 1, 2 * nq, 1, nq + 1, U_, Z_);

    std::array<double, nq * nq> M;
    std::array<double, nq> f, Q{};
    for (int j = 0; j < nq; ++j)
      for (int i = 0; i < nq; ++i) M[i + nq * j] = Z_[1 + j][nq + i][1];
    if constexpr (Info::has_generalized_forces)
      Model::template generalized_forces<double>(t, eom::In<double>(q, nq),
                                                 eom::In<double>(qd, nq),
                                                 eom::In<double>(u, u ? nu : 0),
                                                 eom::In<double>(p, np), Q);
    for (int i = 0; i < nq; ++i) f[i] = Q[i] - Z_[0][nq + i][1] + Z_[0][i][0];

    std::array<double, nc * nq> C{};
    std::array<double, nc> gamma{};
    if constexpr (nc > 0) {
      set_param_vec(tag_phi_, np, const_cast<double*>(p));
      std::array<double, nc> phi;
      for (int i = 0; i < nq; ++i) Xt_[i][0] = qd[i], Xt_[i][1] = 0.0;
      // keep = 1: the reverse sweep for C reuses this forward sweep's values.
      hos_forward(tag_phi_, nc, nq, 2, 1, q, Xt_, phi.data(), Yt_);
      fov_reverse(tag_phi_, nc, nq, nc, Uc_, Cz_);
      for (int k = 0; k < nc; ++k) {
        gamma[k] = 2.0 * Yt_[k][1];  // φ(q + q̇s) = φ + Cq̇ s + ½ q̇ᵀ∇²φ q̇ s² + …
        for (int i = 0; i < nq; ++i) C[k + nc * i] = Cz_[k][i];
      }
    }
    std::array<double, nq> out;
    if (!eom::linalg::solve_constrained<double, nq, nc>(M, f, C, gamma, out.data())) {
      for (int i = 0; i < nq; ++i) qdd[i] = std::numeric_limits<double>::quiet_NaN();
      return false;
    }
    for (int i = 0; i < nq; ++i) qdd[i] = out[i];
    return true;
  }

  // Operations on each tape (ADOL-C's tapestats), for the record.
  std::size_t operations(int which) const {
    std::size_t counts[STAT_SIZE];
    tapestats(which == 0 ? tag_T_ : which == 1 ? tag_L_ : tag_phi_, counts);
    return counts[NUM_OPERATIONS];
  }

 private:
  // The parameters as tape parameters: their values can change without retaping.
  static std::vector<adouble> params_on_tape(const double* p) {
    std::vector<adouble> pa(np);
    for (int i = 0; i < np; ++i) pa[i] = mkparam(p[i]);
    return pa;
  }

  void record_energy(short tag, bool lagrangian, const double* q, const double* qd,
                     const double* p) {
    trace_on(tag, 1);
    std::vector<adouble> qa(nq), qda(nq);
    for (int i = 0; i < nq; ++i) qa[i] <<= q[i];
    for (int i = 0; i < nq; ++i) qda[i] <<= qd[i];
    const std::vector<adouble> pa = params_on_tape(p);
    adouble e = eom::kinetic_energy_of<Model, adouble>(qa, qda, pa);
    if (lagrangian) e = e - Model::template potential_energy<adouble>(qa, pa);
    double value;
    e >>= value;
    trace_off();
  }

  void record_constraints(const double* q, const double* p) {
    trace_on(tag_phi_, 1);
    std::vector<adouble> qa(nq), phi(nc);
    for (int i = 0; i < nq; ++i) qa[i] <<= q[i];
    const std::vector<adouble> pa = params_on_tape(p);
    Model::template constraints<adouble>(qa, pa, phi);
    std::array<double, nc> value;
    for (int k = 0; k < nc; ++k) phi[k] >>= value[k];
    trace_off();
  }

  // ADOL-C's own allocators (contiguous; freed with myfree*).
  static double** matrix2(int a, int b) { return myalloc2(a, b); }
  static double*** matrix3(int a, int b, int c) { return myalloc3(a, b, c); }

  short tag_T_, tag_L_, tag_phi_;
  double*** X_ = nullptr;
  double*** Y_ = nullptr;
  double*** Z_ = nullptr;
  double** U_ = nullptr;
  double** Zvec_ = nullptr;
  double** Uc_ = nullptr;
  double** Cz_ = nullptr;
  double** Xt_ = nullptr;
  double** Yt_ = nullptr;
};

}  // namespace eom_bench
