// svd3 (core/math/svd3.hpp) for L matrices side by side, for the CPU's block kernels: every step a loop across the
// lanes that the compiler vectorises (MPMROM_SIMD), the branches of svd3 turned into per-lane selects. Each lane goes
// through svd3's arithmetic in svd3's order: a lane whose Jacobi sweep rotated nothing is converged and its further
// sweeps (while other lanes rotate) leave it as it is, so a lane's result is svd3's for its matrix, up to how the
// compiler contracts multiply-adds. Parallelism contract: one block of L matrices per call, within the calling thread;
// host code only.
#pragma once

#include "core/math/simd.hpp"
#include "core/math/svd3.hpp"

namespace mpmrom {

namespace detail {

// Applies a lane's rotation [c s; -s c] to columns p and q of A (identity where c = 1, s = 0).
template <int L, class T>
inline void rotate_columns_lanes(T (&A)[3][3][L], int p, int q, const T (&c)[L], const T (&s)[L]) {
  for (int i = 0; i < 3; ++i) {
    MPMROM_SIMD for (int l = 0; l < L; ++l) {
      const T ap = A[i][p][l], aq = A[i][q][l];
      A[i][p][l] = c[l] * ap - s[l] * aq;
      A[i][q][l] = s[l] * ap + c[l] * aq;
    }
  }
}

// Where swap[l] is not 0, swaps columns p and q of A in lane l and negates the new column q (swap_columns_keep_det).
template <int p, int q, int L, class T>
inline void swap_columns_keep_det_lanes(T (&A)[3][3][L], const T (&swap)[L]) {
  for (int i = 0; i < 3; ++i) {
    MPMROM_SIMD for (int l = 0; l < L; ++l) {
      const T ap = A[i][p][l], aq = A[i][q][l];
      A[i][p][l] = swap[l] != T(0) ? aq : ap;
      A[i][q][l] = swap[l] != T(0) ? -ap : aq;
    }
  }
}

// One comparison of svd3's sorting network: where column q's squared norm exceeds column p's, the two columns of B
// and V change places (keeping det V), and their squared norms with them.
template <int p, int q, int L, class T>
inline void sort_pair_lanes(T (&sq)[3][L], T (&B)[3][3][L], T (&V)[3][3][L]) {
  T swap[L];
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    const T sp = sq[p][l], sq_q = sq[q][l];
    swap[l] = sp < sq_q ? T(1) : T(0);
    sq[p][l] = sp < sq_q ? sq_q : sp;
    sq[q][l] = sp < sq_q ? sp : sq_q;
  }
  swap_columns_keep_det_lanes<p, q>(B, swap);
  swap_columns_keep_det_lanes<p, q>(V, swap);
}

// One pair (p, q) of a one-sided Jacobi sweep, as in svd3's loop: each lane's rotation of columns p and q of B (and
// V), the identity where svd3 rotates nothing. Returns whether any lane rotated. p and q are template arguments so
// that the lane loop indexes B at fixed columns, which the vectoriser needs.
template <int p, int q, int L, class T>
inline bool jacobi_pair_lanes(T (&B)[3][3][L], T (&V)[3][3][L]) {
  const T eps = math::epsilon<T>();
  const T tol = T(4) * eps;
  const T zeta_big = T(1) / math::sqrt(eps);
  T c[L], s[L], moves[L];  // moves: 1 where the lane rotates (a T, not a bool, which the vectoriser would not mix)
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    T alpha = T(0), beta = T(0), gamma = T(0);
    for (int i = 0; i < 3; ++i) {
      alpha += B[i][p][l] * B[i][p][l];
      beta += B[i][q][l] * B[i][q][l];
      gamma += B[i][p][l] * B[i][q][l];
    }
    const bool rotate = math::fabs(gamma) > tol * math::sqrt(alpha) * math::sqrt(beta);
    const T safe_gamma = rotate ? gamma : T(1);  // keeps the lanes that do not rotate free of 0/0
    const T zeta = (beta - alpha) / (T(2) * safe_gamma);
    const T abs_zeta = math::fabs(zeta);
    // both roots taken, then one chosen: GCC does not vectorise a division under a condition
    const T t_far = T(1) / (T(2) * abs_zeta);
    const T t_near = T(1) / (abs_zeta + math::sqrt(T(1) + abs_zeta * abs_zeta));
    T t = abs_zeta > zeta_big ? t_far : t_near;
    t = zeta < T(0) ? -t : t;
    const T cl = T(1) / math::sqrt(T(1) + t * t);
    const T sl = cl * t;
    const bool move = rotate & (sl != T(0));
    moves[l] = move ? T(1) : T(0);
    c[l] = move ? cl : T(1);
    s[l] = move ? sl : T(0);
  }
  rotate_columns_lanes(B, p, q, c, s);
  rotate_columns_lanes(V, p, q, c, s);
  bool rotated = false;
  for (int l = 0; l < L; ++l) rotated = rotated || moves[l] != T(0);
  return rotated;
}

// svd3's sweeps over the pairs (0, 1), (0, 2), (1, 2) until no lane rotates or kSvd3MaxSweeps.
template <int L, class T>
inline void jacobi_sweeps_lanes(T (&B)[3][3][L], T (&V)[3][3][L]) {
  for (int sweep = 0; sweep < kSvd3MaxSweeps; ++sweep) {
    bool rotated = jacobi_pair_lanes<0, 1>(B, V);
    rotated = jacobi_pair_lanes<0, 2>(B, V) || rotated;
    rotated = jacobi_pair_lanes<1, 2>(B, V) || rotated;
    if (!rotated) break;
  }
}

}  // namespace detail

// svd3 of the L matrices F[.][.][l]: F = U diag(sigma) V^T per lane, with svd3's conventions (proper rotations,
// sigma sorted by decreasing magnitude, det F's sign on sigma[2]; F = 0 gives U = V = I, sigma = 0).
template <int L, class T>
inline void svd3_lanes(const T (&F)[3][3][L], T (&U)[3][3][L], T (&sigma)[3][L], T (&V)[3][3][L]) {
  T scale[L], B[3][3][L];
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    scale[l] = T(0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) scale[l] = math::max(scale[l], math::fabs(F[i][j][l]));
    const T inv_scale = T(1) / (scale[l] == T(0) ? T(1) : scale[l]);  // F = 0: B = 0, no rotation, I and 0 below
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        B[i][j][l] = inv_scale * F[i][j][l];
        V[i][j][l] = i == j ? T(1) : T(0);
      }
  }
  detail::jacobi_sweeps_lanes(B, V);

  // Sort the columns by decreasing norm with svd3's three-comparison network.
  T sq[3][L];
  for (int j = 0; j < 3; ++j) {
    MPMROM_SIMD for (int l = 0; l < L; ++l) sq[j][l] =
        B[0][j][l] * B[0][j][l] + B[1][j][l] * B[1][j][l] + B[2][j][l] * B[2][j][l];
  }
  detail::sort_pair_lanes<0, 1>(sq, B, V);
  detail::sort_pair_lanes<0, 2>(sq, B, V);
  detail::sort_pair_lanes<1, 2>(sq, B, V);

  const T eps = math::epsilon<T>();
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    const bool zero = scale[l] == T(0);
    const Vec3<T> b1{{B[0][0][l], B[1][0][l], B[2][0][l]}}, b2{{B[0][1][l], B[1][1][l], B[2][1][l]}},
        b3{{B[0][2][l], B[1][2][l], B[2][2][l]}};
    const T s1 = math::sqrt(sq[0][l]);
    const Vec3<T> u1 = (T(1) / (zero ? T(1) : s1)) * b1;
    Vec3<T> r = b2;
    for (int pass = 0; pass < 2; ++pass) r = r - dot(u1, r) * u1;
    const T rn = norm(r);
    // any_orthogonal_unit(u1) without its branches: u1 crossed with the axis least aligned with it
    const T ax = math::fabs(u1[0]), ay = math::fabs(u1[1]), az = math::fabs(u1[2]);
    const int axis = (ax <= ay && ax <= az) ? 0 : (ay <= az ? 1 : 2);
    const Vec3<T> e{{axis == 0 ? T(1) : T(0), axis == 1 ? T(1) : T(0), axis == 2 ? T(1) : T(0)}};
    const Vec3<T> w = cross(u1, e);
    const bool keep = rn > eps * eps;
    const T r_scale = T(1) / (keep ? rn : norm(w));
    const Vec3<T> u2 = r_scale * (keep ? r : w);
    const Vec3<T> u3 = cross(u1, u2);
    const T s3 = math::sqrt(sq[2][l]);
    sigma[0][l] = zero ? T(0) : scale[l] * s1;
    sigma[1][l] = zero ? T(0) : scale[l] * math::sqrt(sq[1][l]);
    sigma[2][l] = zero ? T(0) : scale[l] * (dot(u3, b3) < T(0) ? -s3 : s3);
    for (int i = 0; i < 3; ++i) {
      U[i][0][l] = zero ? T(i == 0) : u1[i];
      U[i][1][l] = zero ? T(i == 1) : u2[i];
      U[i][2][l] = zero ? T(i == 2) : u3[i];
    }
  }
}

}  // namespace mpmrom
