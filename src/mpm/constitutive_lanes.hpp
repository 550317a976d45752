// kirchhoff_stress (mpm/constitutive.hpp) for L deformation gradients side by side, for the CPU's block kernels: the
// fixed corotated model's SVD across the lanes (svd3_lanes), then its stress and energy lane by lane in
// fixed_corotated_kirchhoff's arithmetic; other models call kirchhoff_stress for each lane. Parallelism contract: one
// block of L points per call, within the calling thread; host code only.
#pragma once

#include "core/math/svd3_lanes.hpp"
#include "mpm/constitutive.hpp"

namespace mpmrom {

// tau[.][.][l] = kirchhoff_stress(m, F[.][.][l]) and, where psi is given, psi[l] its energy density.
template <int L, class T>
inline void kirchhoff_stress_lanes(const ElasticMaterial<T>& m, const T (&F)[3][3][L], T (&tau)[3][3][L],
                                   T (*psi)[L] = nullptr) {
  if (m.model != ElasticModel::FixedCorotated) {
    for (int l = 0; l < L; ++l) {
      Mat3<T> Fl;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Fl(i, j) = F[i][j][l];
      const Mat3<T> t = kirchhoff_stress(m, Fl, psi != nullptr ? &(*psi)[l] : nullptr);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) tau[i][j][l] = t(i, j);
    }
    return;
  }
  T U[3][3][L], sigma[3][L], V[3][3][L];
  svd3_lanes(F, U, sigma, V);
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    const T j = F[0][0][l] * (F[1][1][l] * F[2][2][l] - F[1][2][l] * F[2][1][l]) -
                F[0][1][l] * (F[1][0][l] * F[2][2][l] - F[1][2][l] * F[2][0][l]) +
                F[0][2][l] * (F[1][0][l] * F[2][1][l] - F[1][1][l] * F[2][0][l]);  // determinant(F)
    if (psi != nullptr) {
      T stretch = T(0);
      for (int i = 0; i < 3; ++i) stretch += (sigma[i][l] - T(1)) * (sigma[i][l] - T(1));
      (*psi)[l] = m.mu * stretch + T(0.5) * m.lambda * (j - T(1)) * (j - T(1));
    }
    const T volumetric = m.lambda * (j - T(1)) * j;
    T d[3];
    for (int k = 0; k < 3; ++k) d[k] = T(2) * m.mu * (sigma[k][l] - T(1)) * sigma[k][l];
    for (int a = 0; a < 3; ++a)
      for (int b = a; b < 3; ++b) {
        const T s = U[a][0][l] * d[0] * U[b][0][l] + U[a][1][l] * d[1] * U[b][1][l] + U[a][2][l] * d[2] * U[b][2][l];
        tau[a][b][l] = s;
        tau[b][a][l] = s;
      }
    for (int i = 0; i < 3; ++i) tau[i][i][l] += volumetric;
  }
}

}  // namespace mpmrom
