// kirchhoff_stress (mpm/constitutive.hpp) for L deformation gradients side by side, for the CPU's block kernels: the
// fixed corotated model's polar rotation across the lanes (polar_rotation_lanes), then its stress and energy lane by
// lane in fixed_corotated_kirchhoff's arithmetic; other models call kirchhoff_stress for each lane. Parallelism
// contract: one block of L points per call, within the calling thread; host code only.
#pragma once

#include "core/math/polar3_lanes.hpp"
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
  T R[3][3][L];
  polar_rotation_lanes(F, R);
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    T Fl[3][3], Rl[3][3], t[3][3];
    MPMROM_UNROLL
    for (int i = 0; i < 3; ++i) {
      MPMROM_UNROLL
      for (int k = 0; k < 3; ++k) {
        Fl[i][k] = F[i][k][l];
        Rl[i][k] = R[i][k][l];
      }
    }
    const T j = Fl[0][0] * (Fl[1][1] * Fl[2][2] - Fl[1][2] * Fl[2][1]) -
                Fl[0][1] * (Fl[1][0] * Fl[2][2] - Fl[1][2] * Fl[2][0]) +
                Fl[0][2] * (Fl[1][0] * Fl[2][1] - Fl[1][1] * Fl[2][0]);  // determinant(F)
    T energy;
    detail::fixed_corotated_from_rotation(m, Fl, Rl, j, t, &energy);
    if (psi != nullptr) (*psi)[l] = energy;
    MPMROM_UNROLL
    for (int i = 0; i < 3; ++i) {
      MPMROM_UNROLL
      for (int k = 0; k < 3; ++k) tau[i][k][l] = t[i][k];
    }
  }
}

}  // namespace mpmrom
