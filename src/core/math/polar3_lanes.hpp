// polar_rotation (core/math/polar3.hpp) for L matrices side by side, for the CPU's block kernels: Newton's steps as
// loops across the lanes that the compiler vectorises (MPMROM_SIMD; flags held as T, selects instead of branches), a
// converged lane held as it is while others step, so that each lane's result is polar_rotation's for its matrix (up to
// how the compiler contracts multiply-adds); a lane whose iteration fails (det F <= 0, too ill-conditioned, no
// convergence) takes svd3's rotation on its own. Parallelism contract: one block of L matrices per call, within the
// calling thread; host code only.
#pragma once

#include "core/math/polar3.hpp"
#include "core/math/simd.hpp"

namespace mpmrom {

// R[.][.][l] = polar_rotation(F[.][.][l]).
template <int L, class T>
inline void polar_rotation_lanes(const T (&F)[3][3][L], T (&R)[3][3][L]) {
  T stepping[L], failed[L];  // 1 or 0
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    T scale = T(0);
    MPMROM_UNROLL
    for (int i = 0; i < 3; ++i) {
      MPMROM_UNROLL
      for (int j = 0; j < 3; ++j) scale = math::max(scale, math::fabs(F[i][j][l]));
    }
    const bool usable = scale > T(0) && math::isfinite(scale);
    stepping[l] = usable ? T(1) : T(0);
    failed[l] = usable ? T(0) : T(1);
    const T inv_scale = T(1) / (usable ? scale : T(1));
    MPMROM_UNROLL
    for (int i = 0; i < 3; ++i) {
      MPMROM_UNROLL
      for (int j = 0; j < 3; ++j) R[i][j][l] = inv_scale * F[i][j][l];
    }
  }
  for (int k = 0; k < kPolar3MaxIterations; ++k) {
    MPMROM_SIMD for (int l = 0; l < L; ++l) {
      T x[3][3];
      MPMROM_UNROLL
      for (int i = 0; i < 3; ++i) {
        MPMROM_UNROLL
        for (int j = 0; j < 3; ++j) x[i][j] = R[i][j][l];
      }
      T condition;
      const T change = detail::polar_newton_step(x, condition);
      const bool fail = change < T(0) || (k == 0 && !(condition <= T(kPolar3MaxCondition)));
      const bool step = stepping[l] != T(0) && !fail;
      MPMROM_UNROLL
      for (int i = 0; i < 3; ++i) {
        MPMROM_UNROLL
        for (int j = 0; j < 3; ++j) R[i][j][l] = step ? x[i][j] : R[i][j][l];
      }
      failed[l] = stepping[l] != T(0) && fail ? T(1) : failed[l];
      stepping[l] = step && !detail::polar_newton_converged(change) ? T(1) : T(0);
    }
    T any = T(0);
    for (int l = 0; l < L; ++l) any += stepping[l];
    if (any == T(0)) break;
  }
  for (int l = 0; l < L; ++l) {
    if (stepping[l] == T(0) && failed[l] == T(0)) continue;  // converged
    Mat3<T> Fl;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Fl(i, j) = F[i][j][l];
    const Mat3<T> Rl = detail::svd_rotation(Fl);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R[i][j][l] = Rl(i, j);
  }
}

}  // namespace mpmrom
