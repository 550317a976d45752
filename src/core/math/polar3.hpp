// The rotation R of the polar decomposition F = R S of a 3x3 matrix, for the fixed corotated stress: Newton's
// iteration where det F > 0 (several times cheaper than svd3: a cofactor matrix a step, one square root, no plane
// rotations), svd3 where it is not. Parallelism contract: one matrix per call, within the calling thread.
#pragma once

#include "core/math/svd3.hpp"
#include "core/math/unroll.hpp"

namespace mpmrom {

// Upper bound on Newton steps. Measured over 2e5 random F = Q S each: strains of 1 % take 3 steps in double and 2 in
// float, 10 % 4 and 3, principal stretches in [0.5, 2] at most 5 and 4, in [0.1, 10] (within the condition limit
// below) at most 6 and 5; the cap only bounds the work for input past those, which then takes svd3.
constexpr int kPolar3MaxIterations = 12;

// Newton's inverse by the cofactor matrix carries rounding errors of about eps |F| |F^{-1}|; above this Frobenius
// condition number (3 for a rotation; principal stretches about 20-30 to 1) the caller takes svd3 instead, whose error
// does not grow with it. Elastic states lie far below it.
constexpr double kPolar3MaxCondition = 30;

namespace detail {

// One scaled Newton step X <- (zeta X + (zeta X)^{-T}) / 2 with Higham's Frobenius-norm scaling
// zeta = sqrt(|X^{-1}|_F / |X|_F) (|X^{-1}|_F = |cof X|_F / det X): the iterates converge quadratically to R, the
// scaling makes the first steps of an ill-conditioned X count and tends to 1 as X nears R. Returns
// |X_new - X|_F^2, or -1 where det X is not positive and finite (the iteration would leave the rotations); condition
// receives |X|_F |X^{-1}|_F (3 for a rotation), or twice kPolar3MaxCondition where det X < 1e-3 |X|_F^3 (which any X
// within the limit exceeds: det X / |X|_F^3 is at least about 2e-3 there).
template <class T>
KOKKOS_INLINE_FUNCTION T polar_newton_step(T (&x)[3][3], T& condition) {
  const T c[3][3] = {{x[1][1] * x[2][2] - x[1][2] * x[2][1], x[1][2] * x[2][0] - x[1][0] * x[2][2],
                      x[1][0] * x[2][1] - x[1][1] * x[2][0]},
                     {x[0][2] * x[2][1] - x[0][1] * x[2][2], x[0][0] * x[2][2] - x[0][2] * x[2][0],
                      x[0][1] * x[2][0] - x[0][0] * x[2][1]},
                     {x[0][1] * x[1][2] - x[0][2] * x[1][1], x[0][2] * x[1][0] - x[0][0] * x[1][2],
                      x[0][0] * x[1][1] - x[0][1] * x[1][0]}};  // cof(X), as cofactor() in mat3.hpp
  const T det = x[0][0] * c[0][0] + x[0][1] * c[0][1] + x[0][2] * c[0][2];
  const bool ok = det > T(0) && math::isfinite(det);  // selects, not branches: the lanes' loops vectorise
  const T safe_det = ok ? det : T(1);
  T cc = T(0), xx = T(0);
  MPMROM_UNROLL
  for (int i = 0; i < 3; ++i) {
    MPMROM_UNROLL
    for (int j = 0; j < 3; ++j) {
      cc += c[i][j] * c[i][j];
      xx += x[i][j] * x[i][j];
    }
  }
  const T norm_c = math::sqrt(cc), norm_x = math::sqrt(xx);
  // |X|_F |X^{-1}|_F; above the limit where det X is at rounding level (for rank <= 1, cof X is too: the ratio is
  // noise)
  condition = safe_det > T(1e-3) * xx * norm_x ? norm_x * norm_c / safe_det : T(2 * kPolar3MaxCondition);
  const T zeta = math::sqrt(norm_c / (safe_det * norm_x));
  const T a = T(0.5) * zeta, b = T(0.5) / (zeta * safe_det);
  T change = T(0);
  MPMROM_UNROLL
  for (int i = 0; i < 3; ++i) {
    MPMROM_UNROLL
    for (int j = 0; j < 3; ++j) {
      const T next = a * x[i][j] + b * c[i][j];
      change += (next - x[i][j]) * (next - x[i][j]);
      x[i][j] = ok ? next : x[i][j];
    }
  }
  return ok ? change : T(-1);
}

// svd3's rotation U V^T: polar_rotation where Newton's iteration does not apply.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> svd_rotation(const Mat3<T>& F) {
  Mat3<T> U, V;
  Vec3<T> sigma;
  svd3(F, U, sigma, V);
  return multiply_transposed(U, V);
}

// Whether a Newton step that moved X by |dX|_F^2 = change leaves X within a few eps of R: the error after a step is
// about the square of the step's size.
template <class T>
KOKKOS_INLINE_FUNCTION bool polar_newton_converged(T change) {
  return change <= T(4) * math::epsilon<T>();
}

}  // namespace detail

// R of F = R S by Newton's iteration, for det F > 0: true with R a rotation to a few eps; false (R undefined) where
// det F <= 0, an entry is not finite, F's condition exceeds kPolar3MaxCondition, or the iteration does not converge
// within kPolar3MaxIterations. F is scaled by its largest entry first, so nothing overflows.
template <class T>
KOKKOS_INLINE_FUNCTION bool polar_rotation_newton(const Mat3<T>& F, Mat3<T>& R) {
  T scale = T(0);
  MPMROM_UNROLL
  for (int i = 0; i < 3; ++i) {
    MPMROM_UNROLL
    for (int j = 0; j < 3; ++j) scale = math::max(scale, math::fabs(F(i, j)));
  }
  if (!(scale > T(0)) || !math::isfinite(scale)) return false;
  R = (T(1) / scale) * F;
  for (int k = 0; k < kPolar3MaxIterations; ++k) {
    T condition;
    const T change = detail::polar_newton_step(R.m, condition);
    if (change < T(0) || (k == 0 && !(condition <= T(kPolar3MaxCondition)))) return false;
    if (detail::polar_newton_converged(change)) return true;
  }
  return false;
}

// Rotation of the rotation-variant polar decomposition F = R S: R = U V^T of svd3, a proper rotation even when
// det F <= 0 (then the symmetric S = V diag(sigma) V^T carries the reflection). Unique where sigma[1] + sigma[2] > 0.
// Newton's iteration where det F > 0 (the two agree to a few eps |F| / (sigma[1] + sigma[2])), svd3 otherwise.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> polar_rotation(const Mat3<T>& F) {
  Mat3<T> R;
  return polar_rotation_newton(F, R) ? R : detail::svd_rotation(F);
}

}  // namespace mpmrom
