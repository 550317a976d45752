// Fixed-size 3-vectors and 3x3 matrices for device code: value types with no heap, no Eigen, every routine a
// KOKKOS_INLINE_FUNCTION. Parallelism contract: each routine runs entirely within the calling thread.
#pragma once

#include "core/kokkos_compat.hpp"

namespace mpmrom {

template <class T>
struct Vec3 {
  T v[3];

  KOKKOS_INLINE_FUNCTION T& operator[](int i) { return v[i]; }
  KOKKOS_INLINE_FUNCTION const T& operator[](int i) const { return v[i]; }
  KOKKOS_INLINE_FUNCTION static Vec3 zero() { return {{T(0), T(0), T(0)}}; }
};

template <class T>
struct Mat3 {
  T m[3][3];  // row-major: m[row][column]

  KOKKOS_INLINE_FUNCTION T& operator()(int i, int j) { return m[i][j]; }
  KOKKOS_INLINE_FUNCTION const T& operator()(int i, int j) const { return m[i][j]; }
  KOKKOS_INLINE_FUNCTION static Mat3 zero() {
    Mat3 a;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a.m[i][j] = T(0);
    return a;
  }
  KOKKOS_INLINE_FUNCTION static Mat3 identity() {
    Mat3 a = zero();
    a.m[0][0] = a.m[1][1] = a.m[2][2] = T(1);
    return a;
  }
  KOKKOS_INLINE_FUNCTION static Mat3 diagonal(T a0, T a1, T a2) {
    Mat3 a = zero();
    a.m[0][0] = a0;
    a.m[1][1] = a1;
    a.m[2][2] = a2;
    return a;
  }
};

// ---- vectors ----
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> operator+(const Vec3<T>& a, const Vec3<T>& b) {
  return {{a[0] + b[0], a[1] + b[1], a[2] + b[2]}};
}
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> operator-(const Vec3<T>& a, const Vec3<T>& b) {
  return {{a[0] - b[0], a[1] - b[1], a[2] - b[2]}};
}
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> operator*(T s, const Vec3<T>& a) {
  return {{s * a[0], s * a[1], s * a[2]}};
}
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T>& operator+=(Vec3<T>& a, const Vec3<T>& b) {
  for (int i = 0; i < 3; ++i) a[i] += b[i];
  return a;
}
template <class T>
KOKKOS_INLINE_FUNCTION T dot(const Vec3<T>& a, const Vec3<T>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}};
}
template <class T>
KOKKOS_INLINE_FUNCTION T norm(const Vec3<T>& a) {
  return math::sqrt(dot(a, a));
}

// ---- matrices ----
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> operator+(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = a(i, j) + b(i, j);
  return c;
}
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> operator-(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = a(i, j) - b(i, j);
  return c;
}
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> operator*(T s, const Mat3<T>& a) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = s * a(i, j);
  return c;
}
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T>& operator+=(Mat3<T>& a, const Mat3<T>& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a(i, j) += b(i, j);
  return a;
}
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> operator*(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = a(i, 0) * b(0, j) + a(i, 1) * b(1, j) + a(i, 2) * b(2, j);
  return c;
}
template <class T>
KOKKOS_INLINE_FUNCTION Vec3<T> operator*(const Mat3<T>& a, const Vec3<T>& x) {
  return {{a(0, 0) * x[0] + a(0, 1) * x[1] + a(0, 2) * x[2], a(1, 0) * x[0] + a(1, 1) * x[1] + a(1, 2) * x[2],
           a(2, 0) * x[0] + a(2, 1) * x[1] + a(2, 2) * x[2]}};
}
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> transpose(const Mat3<T>& a) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = a(j, i);
  return c;
}
// a * b^T without forming the transpose.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> multiply_transposed(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = a(i, 0) * b(j, 0) + a(i, 1) * b(j, 1) + a(i, 2) * b(j, 2);
  return c;
}
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> outer(const Vec3<T>& a, const Vec3<T>& b) {
  Mat3<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = a[i] * b[j];
  return c;
}
template <class T>
KOKKOS_INLINE_FUNCTION T trace(const Mat3<T>& a) {
  return a(0, 0) + a(1, 1) + a(2, 2);
}
// Frobenius inner product a : b.
template <class T>
KOKKOS_INLINE_FUNCTION T ddot(const Mat3<T>& a, const Mat3<T>& b) {
  T s = T(0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += a(i, j) * b(i, j);
  return s;
}
template <class T>
KOKKOS_INLINE_FUNCTION T frobenius_norm(const Mat3<T>& a) {
  return math::sqrt(ddot(a, a));
}
template <class T>
KOKKOS_INLINE_FUNCTION T determinant(const Mat3<T>& a) {
  return a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0)) +
         a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
}
// Cofactor matrix: cof(A) = det(A) A^{-T}, defined also for singular A (the derivative of det).
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> cofactor(const Mat3<T>& a) {
  Mat3<T> c;
  c(0, 0) = a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1);
  c(0, 1) = a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2);
  c(0, 2) = a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0);
  c(1, 0) = a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2);
  c(1, 1) = a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0);
  c(1, 2) = a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1);
  c(2, 0) = a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1);
  c(2, 1) = a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2);
  c(2, 2) = a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0);
  return c;
}
// Inverse by the adjugate; the caller guarantees det(a) != 0.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> inverse(const Mat3<T>& a) {
  return (T(1) / determinant(a)) * transpose(cofactor(a));
}

}  // namespace mpmrom
