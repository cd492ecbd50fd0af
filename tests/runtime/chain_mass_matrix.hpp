// The chain's mass matrix in closed form (models/chain.hpp): M_ij = cos(θi − θj) Σ_k m_k a_ki a_kj
// + I_i δ_ij, with a_ki = l_i (i < k), l_i/2 (i = k), 0 (i > k): the mass centre of link k moves
// with link i's rotation only through the links before it.
#pragma once

#include <algorithm>
#include <cmath>

// max |M − closed form| / max |closed form| for Chain<N> at (q, p), M column-major N × N.
template <int N> double chain_mass_matrix_error(const double* q, const double* p, const double* M) {
  auto a = [&](int k, int i) { return i < k ? p[N + i] : i == k ? 0.5 * p[N + i] : 0.0; };
  double err = 0, scale = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) {
      double s = 0;
      for (int k = 0; k < N; ++k) s += p[k] * a(k, i) * a(k, j);
      const double want = std::cos(q[i] - q[j]) * s + (i == j ? p[2 * N + i] : 0.0);
      err = std::max(err, std::abs(M[i + N * j] - want));
      scale = std::max(scale, std::abs(want));
    }
  return err / scale;
}
