// Rotation-variant SVD of a 3x3 matrix by one-sided Jacobi (its polar rotation: core/math/polar3.hpp). Parallelism
// contract: each routine runs entirely within the calling thread (one matrix per call; no heap, no recursion, bounded
// loops).
#pragma once

#include "core/math/mat3.hpp"

namespace mpmrom {

// Upper bound on one-sided Jacobi sweeps. Convergence is quadratic: at most 6 sweeps (the last finds nothing left to
// rotate) in double and in float, measured over 10^5 random, rank-deficient and near-singular matrices; the cap only
// bounds the work for pathological input (NaN).
constexpr int kSvd3MaxSweeps = 12;

namespace detail {

template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> column(const Mat3<T>& a, int j) {
  return {{a(0, j), a(1, j), a(2, j)}};
}

// Applies the plane rotation [c s; -s c] to columns p and q of a: a_p <- c a_p - s a_q, a_q <- s a_p + c a_q.
template <class T>
KOKKOS_INLINE_FUNCTION void rotate_columns(Mat3<T>& a, int p, int q, T c, T s) {
  for (int i = 0; i < 3; ++i) {
    const T ap = a(i, p), aq = a(i, q);
    a(i, p) = c * ap - s * aq;
    a(i, q) = s * ap + c * aq;
  }
}

// Swaps columns p and q of a and negates the new column q, which keeps det(a) unchanged.
template <class T>
KOKKOS_INLINE_FUNCTION void swap_columns_keep_det(Mat3<T>& a, int p, int q) {
  for (int i = 0; i < 3; ++i) {
    const T ap = a(i, p);
    a(i, p) = a(i, q);
    a(i, q) = -ap;
  }
}

// A unit vector orthogonal to the unit vector u: u crossed with the coordinate axis least aligned with it.
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> any_orthogonal_unit(const Vec3<T>& u) {
  const T ax = math::fabs(u[0]), ay = math::fabs(u[1]), az = math::fabs(u[2]);
  Vec3<T> e = Vec3<T>::zero();
  e[(ax <= ay && ax <= az) ? 0 : (ay <= az ? 1 : 2)] = T(1);
  const Vec3<T> w = cross(u, e);  // |w| >= sqrt(2/3)
  return (T(1) / norm(w)) * w;
}

}  // namespace detail

// F = U diag(sigma) V^T with U and V proper rotations (det +1), sigma[0] >= sigma[1] >= |sigma[2]|, and the sign of
// det(F) carried by sigma[2] alone (the rotation-variant SVD of Irving et al. 2004 and Stomakhin et al. 2012).
//
// Algorithm: one-sided (Hestenes) Jacobi on the columns of B = F V. Plane rotations V <- V G orthogonalise the columns
// of B pairwise, cyclically, until every pair satisfies |b_p . b_q| <= 4 eps |b_p| |b_q| (at most kSvd3MaxSweeps
// sweeps). F^T F is never formed, so the condition number is not squared: B stays within a few eps |F| of F V and tiny
// singular values keep their direction. The columns are then sorted by decreasing norm (each swap negates one column so
// det V stays +1), sigma_i = |b_i|, u1 = b1 / |b1|, u2 = b2 Gram-Schmidt-orthogonalised against u1 (any unit vector
// orthogonal to u1 if b2 is negligible: rank <= 1), u3 = u1 x u2 (so det U = +1 even for rank-deficient F), and sigma3
// takes the sign of u3 . b3, i.e. of det F. F is scaled by its largest entry first, so nothing overflows for any finite
// F and underflow only touches singular values far below eps |F|. F = 0 gives U = V = I, sigma = 0. An entry that is
// NaN or infinite gives a non-finite sigma.
template <class T>
KOKKOS_INLINE_FUNCTION void svd3(const Mat3<T>& F, Mat3<T>& U, Vec3<T>& sigma, Mat3<T>& V) {
  U = Mat3<T>::identity();
  V = Mat3<T>::identity();
  T scale = T(0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) scale = math::max(scale, math::fabs(F(i, j)));
  if (scale == T(0)) {
    sigma = Vec3<T>::zero();
    return;
  }
  const T inv_scale = T(1) / scale;
  Mat3<T> B = inv_scale * F;  // entries in [-1, 1]

  const T eps = math::epsilon<T>();
  const T tol = T(4) * eps;  // a computed dot product carries up to 3 eps |b_p| |b_q| of rounding
  // Past this |zeta|, 1 + zeta^2 rounds to zeta^2 and t = 1 / (2 zeta) to working precision; it also keeps zeta^2
  // from overflowing in float.
  const T zeta_big = T(1) / math::sqrt(eps);
  for (int sweep = 0; sweep < kSvd3MaxSweeps; ++sweep) {
    bool rotated = false;
    for (int pair = 0; pair < 3; ++pair) {
      const int p = pair == 2 ? 1 : 0;
      const int q = pair == 0 ? 1 : 2;
      T alpha = T(0), beta = T(0), gamma = T(0);
      for (int i = 0; i < 3; ++i) {
        alpha += B(i, p) * B(i, p);
        beta += B(i, q) * B(i, q);
        gamma += B(i, p) * B(i, q);
      }
      if (!(math::fabs(gamma) > tol * math::sqrt(alpha) * math::sqrt(beta))) continue;
      // Rotation angle that makes columns p and q orthogonal; t = tan(theta) is the root of t^2 + 2 zeta t - 1 = 0
      // of smaller magnitude, so |theta| <= pi/4.
      const T zeta = (beta - alpha) / (T(2) * gamma);
      const T abs_zeta = math::fabs(zeta);
      T t = abs_zeta > zeta_big ? T(1) / (T(2) * abs_zeta) : T(1) / (abs_zeta + math::sqrt(T(1) + abs_zeta * abs_zeta));
      if (zeta < T(0)) t = -t;
      const T c = T(1) / math::sqrt(T(1) + t * t);
      const T s = c * t;
      if (s == T(0)) continue;  // gamma is too small to move anything in this precision
      detail::rotate_columns(B, p, q, c, s);
      detail::rotate_columns(V, p, q, c, s);
      rotated = true;
    }
    if (!rotated) break;
  }

  // Sort the columns by decreasing norm with a three-comparison network.
  Vec3<T> sq;
  for (int j = 0; j < 3; ++j) sq[j] = dot(detail::column(B, j), detail::column(B, j));
  const int net[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int k = 0; k < 3; ++k) {
    const int p = net[k][0], q = net[k][1];
    if (sq[p] < sq[q]) {
      math::swap(sq[p], sq[q]);
      detail::swap_columns_keep_det(B, p, q);
      detail::swap_columns_keep_det(V, p, q);
    }
  }

  const Vec3<T> b1 = detail::column(B, 0), b2 = detail::column(B, 1), b3 = detail::column(B, 2);
  const T s1 = math::sqrt(sq[0]);  // >= 1/sqrt(3): |B|_F = |F|_F / scale >= 1
  const Vec3<T> u1 = (T(1) / s1) * b1;
  // Gram-Schmidt twice ("twice is enough", Giraud et al. 2005); b2 is orthogonal to b1 up to tol already.
  Vec3<T> r = b2;
  for (int pass = 0; pass < 2; ++pass) r = r - dot(u1, r) * u1;
  const T rn = norm(r);
  // Below eps^2 (relative to s1 >= 1/sqrt(3)) b2 carries no direction worth keeping and dropping it perturbs F by far
  // less than eps |F|; this also keeps denormals out of the normalisation.
  const Vec3<T> u2 = rn > eps * eps ? (T(1) / rn) * r : detail::any_orthogonal_unit(u1);
  const Vec3<T> u3 = cross(u1, u2);
  const T s3 = math::sqrt(sq[2]);
  sigma[0] = scale * s1;
  sigma[1] = scale * math::sqrt(sq[1]);
  sigma[2] = scale * (dot(u3, b3) < T(0) ? -s3 : s3);
  for (int i = 0; i < 3; ++i) {
    U(i, 0) = u1[i];
    U(i, 1) = u2[i];
    U(i, 2) = u3[i];
  }
}

}  // namespace mpmrom
