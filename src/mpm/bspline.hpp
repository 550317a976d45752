// Quadratic B-spline interpolation weights on a regular grid (Steffen et al. 2008; Jiang et al. 2016, sec. 9.3).
// Parallelism contract: one particle per call, entirely within the calling thread.
#pragma once

#include "core/math/mat3.hpp"
#include "core/math/simd.hpp"

namespace mpmrom {

// The 3x3x3 stencil of grid nodes whose quadratic B-spline is non-zero at one point.
template <class T>
struct QuadraticStencil {
  int base[3];  // index of the stencil's first node along each axis
  T w[3][3];    // w[axis][a]: 1D weight of node base[axis] + a
  T dw[3][3];   // dw[axis][a]: derivative of that 1D weight with respect to the coordinate (1/length)

  // Weight N_i of node base + (a, b, c).
  KOKKOS_INLINE_FUNCTION T weight(int a, int b, int c) const { return w[0][a] * w[1][b] * w[2][c]; }
  // Gradient of N_i with respect to the point's position.
  KOKKOS_INLINE_FUNCTION Vec3<T> gradient(int a, int b, int c) const {
    return {{dw[0][a] * w[1][b] * w[2][c], w[0][a] * dw[1][b] * w[2][c], w[0][a] * w[1][b] * dw[2][c]}};
  }
  // gradient(a, b, c)[axis], the same products, without a vector indexed at run time (which GPU code keeps on the
  // stack).
  KOKKOS_INLINE_FUNCTION T gradient_component(int a, int b, int c, int axis) const {
    return (axis == 0 ? dw[0][a] : w[0][a]) * (axis == 1 ? dw[1][b] : w[1][b]) * (axis == 2 ? dw[2][c] : w[2][c]);
  }
  // Offset from the point to node base + (a, b, c), in length units; APIC needs it.
  KOKKOS_INLINE_FUNCTION Vec3<T> node_offset(int a, int b, int c, const Vec3<T>& x, const Vec3<T>& origin, T dx) const {
    return {{origin[0] + T(base[0] + a) * dx - x[0], origin[1] + T(base[1] + b) * dx - x[1],
             origin[2] + T(base[2] + c) * dx - x[2]}};
  }
};

// Node k sits at origin + k * dx. The kernel of node k is N((x - x_k) / dx) with the quadratic B-spline
// N(s) = 3/4 - s^2 for |s| < 1/2, (3/2 - |s|)^2 / 2 for 1/2 <= |s| < 3/2, and 0 beyond.
template <class T>
KOKKOS_INLINE_FUNCTION QuadraticStencil<T> quadratic_stencil(const Vec3<T>& x, const Vec3<T>& origin, T inv_dx) {
  QuadraticStencil<T> s;
  for (int d = 0; d < 3; ++d) {
    const T xi = (x[d] - origin[d]) * inv_dx;
    const int base = static_cast<int>(math::floor(xi - T(0.5)));
    const T f = xi - T(base);  // in [0.5, 1.5): distance to the first node, in cells
    s.base[d] = base;
    const T f0 = T(1.5) - f, f1 = f - T(1), f2 = f - T(0.5);
    s.w[d][0] = T(0.5) * f0 * f0;
    s.w[d][1] = T(0.75) - f1 * f1;
    s.w[d][2] = T(0.5) * f2 * f2;
    s.dw[d][0] = -f0 * inv_dx;
    s.dw[d][1] = T(-2) * f1 * inv_dx;
    s.dw[d][2] = f2 * inv_dx;
  }
  return s;
}

// quadratic_stencil's base node and 1D weights along one axis for L points side by side (the CPU's block kernels:
// the lane loop vectorised; the same arithmetic per point).
template <int L, class T>
KOKKOS_INLINE_FUNCTION void quadratic_weights_lanes(const T (&x)[L], T origin, T inv_dx, int (&base)[L], T (&w)[3][L],
                                                    T (&dw)[3][L]) {
  MPMROM_SIMD for (int l = 0; l < L; ++l) {
    const T xi = (x[l] - origin) * inv_dx;
    base[l] = static_cast<int>(math::floor(xi - T(0.5)));
    const T f = xi - T(base[l]);
    const T f0 = T(1.5) - f, f1 = f - T(1), f2 = f - T(0.5);
    w[0][l] = T(0.5) * f0 * f0;
    w[1][l] = T(0.75) - f1 * f1;
    w[2][l] = T(0.5) * f2 * f2;
    dw[0][l] = -f0 * inv_dx;
    dw[1][l] = T(-2) * f1 * inv_dx;
    dw[2][l] = f2 * inv_dx;
  }
}

// Node base + (a, b, c) of lane l's stencil (quadratic_weights_lanes' arrays): its weight, the weight's gradient and
// the offset from the point to the node, in QuadraticStencil's weight, gradient and node_offset arithmetic.
template <int L, class T>
KOKKOS_INLINE_FUNCTION void stencil_node_lane(int a, int b, int c, int l, const T (&w)[3][3][L], const T (&dw)[3][3][L],
                                              const int (&base)[3][L], const T (&x)[3][L], const Vec3<T>& origin, T dx,
                                              T& weight, T (&gradient)[3], T (&offset)[3]) {
  weight = w[0][a][l] * w[1][b][l] * w[2][c][l];
  gradient[0] = dw[0][a][l] * w[1][b][l] * w[2][c][l];
  gradient[1] = w[0][a][l] * dw[1][b][l] * w[2][c][l];
  gradient[2] = w[0][a][l] * w[1][b][l] * dw[2][c][l];
  offset[0] = origin[0] + T(base[0][l] + a) * dx - x[0][l];
  offset[1] = origin[1] + T(base[1][l] + b) * dx - x[1][l];
  offset[2] = origin[2] + T(base[2][l] + c) * dx - x[2][l];
}

}  // namespace mpmrom
