// The network run over every (code, point) pair: g, and on request F = dg/dX, dg/dxhat and the velocity. One
// thread a pair (the one-point kernels of mlp.hpp) on GPUs; on CPUs blocks of consecutive pairs, one a thread
// (mlp_block.hpp), whose lanes the compiler vectorises.
#pragma once

#include <type_traits>

#include "core/math/simd.hpp"
#include "manifold/nn/mlp.hpp"
#include "manifold/nn/mlp_block.hpp"

namespace mpmrom::nn {

namespace impl {

template <int MaxWidth, class T, class MemorySpace>
struct Evaluate {
  Mlp<T, MemorySpace> mlp;
  PointsView<T, MemorySpace> X;
  CodesView<T, MemorySpace> codes;
  Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace> g;

  KOKKOS_INLINE_FUNCTION void operator()(const long e) const {
    const int num_points = int(X.extent(0));
    const int b = int(e / num_points), p = int(e % num_points);
    const T Xp[3] = {X(p, 0), X(p, 1), X(p, 2)};
    T gp[3];
    SerialMlpForward<MaxWidth>(mlp, Xp, &codes(b, 0), gp);
    for (int k = 0; k < 3; ++k) g(b, p, k) = gp[k];
  }
};

template <int MaxWidth, class T, class MemorySpace>
struct EvaluateWithJacobians {
  Mlp<T, MemorySpace> mlp;
  PointsView<T, MemorySpace> X;
  CodesView<T, MemorySpace> codes;
  CodesView<T, MemorySpace> code_rates;  // may be empty: no velocity
  Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace> g;
  Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace> F;
  Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace> dgdxhat;
  Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace> velocity;

  KOKKOS_INLINE_FUNCTION void operator()(const long e) const {
    const int num_points = int(X.extent(0));
    const int r = mlp.layout.latent_dim;
    const int b = int(e / num_points), p = int(e % num_points);
    const T Xp[3] = {X(p, 0), X(p, 1), X(p, 2)};
    T gp[3], Fp[3][3];
    T* J = &dgdxhat(b, p, 0, 0);
    SerialMlpForwardJacobian<MaxWidth>(mlp, Xp, &codes(b, 0), gp, Fp, J);
    for (int i = 0; i < 3; ++i) {
      g(b, p, i) = gp[i];
      for (int j = 0; j < 3; ++j) F(b, p, i, j) = Fp[i][j];
    }
    if (velocity.extent(0) == 0) return;
    for (int i = 0; i < 3; ++i) {
      T v = 0;
      for (int q = 0; q < r; ++q) v += J[i * r + q] * code_rates(b, q);
      velocity(b, p, i) = v;
    }
  }
};

// The pairs of block `block` (item e: point e % points at code e / points), the lanes past the last pair repeating
// it; returns how many pairs it holds.
template <int Lanes, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION int gather_block(const PointsView<T, MemorySpace>& X, const CodesView<T, MemorySpace>& codes,
                                        long block, PointBlock<Lanes, T>& points, int (&b)[Lanes], int (&p)[Lanes]) {
  const long num_points = long(X.extent(0)), n = long(codes.extent(0)) * num_points;
  const long first = block * Lanes;
  const int count = int(n - first < Lanes ? n - first : Lanes);
  for (int lane = 0; lane < Lanes; ++lane) {
    const long e = first + (lane < count ? lane : count - 1);
    b[lane] = int(e / num_points);
    p[lane] = int(e % num_points);
    for (int d = 0; d < 3; ++d) points.X[lane][d] = X(p[lane], d);
    points.xhat[lane] = &codes(b[lane], 0);
  }
  return count;
}

template <int MaxWidth, class T, class MemorySpace>
struct EvaluateBlocks {
  static constexpr int Lanes = host_block_lanes;
  Mlp<T, MemorySpace> mlp;
  PointsView<T, MemorySpace> X;
  CodesView<T, MemorySpace> codes;
  Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace> g;

  KOKKOS_INLINE_FUNCTION void operator()(const long block) const {
    PointBlock<Lanes, T> points;
    int b[Lanes], p[Lanes];
    const int count = gather_block(X, codes, block, points, b, p);
    T gp[Lanes][3];
    BlockMlpForward<Lanes, MaxWidth>(mlp, points, gp);
    for (int lane = 0; lane < count; ++lane)
      for (int k = 0; k < 3; ++k) g(b[lane], p[lane], k) = gp[lane][k];
  }
};

template <int MaxWidth, class T, class MemorySpace>
struct EvaluateWithJacobiansBlocks {
  static constexpr int Lanes = host_block_lanes;
  EvaluateWithJacobians<MaxWidth, T, MemorySpace> out;  // the views, as the one-pair functor's

  KOKKOS_INLINE_FUNCTION void operator()(const long block) const {
    PointBlock<Lanes, T> points;
    int b[Lanes], p[Lanes];
    const int count = gather_block(out.X, out.codes, block, points, b, p);
    const int r = out.mlp.layout.latent_dim;
    T gp[Lanes][3], Fp[Lanes][3][3];
    T padding[3 * max_width];  // the repeated lanes' dg/dxhat
    T* J[Lanes];
    for (int lane = 0; lane < Lanes; ++lane) J[lane] = lane < count ? &out.dgdxhat(b[lane], p[lane], 0, 0) : padding;
    BlockMlpForwardJacobian<Lanes, MaxWidth>(out.mlp, points, gp, Fp, J);
    for (int lane = 0; lane < count; ++lane) {
      const int bl = b[lane], pl = p[lane];
      for (int i = 0; i < 3; ++i) {
        out.g(bl, pl, i) = gp[lane][i];
        for (int j = 0; j < 3; ++j) out.F(bl, pl, i, j) = Fp[lane][i][j];
      }
      if (out.velocity.extent(0) == 0) continue;
      for (int i = 0; i < 3; ++i) {
        T v = 0;
        for (int q = 0; q < r; ++q) v += J[lane][i * r + q] * out.code_rates(bl, q);
        out.velocity(bl, pl, i) = v;
      }
    }
  }
};

// Blocks on CPUs whose compiler vectorises their lanes (math::host_lane_blocks), one thread a pair elsewhere.
template <class ExecutionSpace>
inline constexpr bool evaluate_in_blocks =
    math::host_lane_blocks&& Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible;

}  // namespace impl

// g(X_p; xhat_b) for every point p and code b: g (codes, points, 3).
template <class ExecutionSpace, class T, class MemorySpace>
void evaluate(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp, const PointsView<T, MemorySpace>& X,
              const CodesView<T, MemorySpace>& codes, const Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>& g) {
  const long n = long(codes.extent(0)) * long(X.extent(0));
  using Range = Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>;
  dispatch_max_width(mlp.layout.widest, [&](auto width) {
    constexpr int W = decltype(width)::value;
    if constexpr (impl::evaluate_in_blocks<ExecutionSpace>) {
      const long blocks = (n + host_block_lanes - 1) / host_block_lanes;
      Kokkos::parallel_for("mpmrom::nn::evaluate", Range(space, 0, blocks),
                           impl::EvaluateBlocks<W, T, MemorySpace>{mlp, X, codes, g});
    } else {
      Kokkos::parallel_for("mpmrom::nn::evaluate", Range(space, 0, n),
                           impl::Evaluate<W, T, MemorySpace>{mlp, X, codes, g});
    }
  });
}

// For every point p and code b: g (codes, points, 3), F = dg/dX (codes, points, 3, 3), dg/dxhat (codes, points, 3, r)
// and, when code_rates (codes, r) and velocity (codes, points, 3) are not empty, the velocity dg/dxhat * xhatdot.
template <class ExecutionSpace, class T, class MemorySpace>
void evaluate_with_jacobians(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp,
                             const PointsView<T, MemorySpace>& X, const CodesView<T, MemorySpace>& codes,
                             const CodesView<T, MemorySpace>& code_rates,
                             const Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>& g,
                             const Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace>& F,
                             const Kokkos::View<T****, Kokkos::LayoutRight, MemorySpace>& dgdxhat,
                             const Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>& velocity) {
  const long n = long(codes.extent(0)) * long(X.extent(0));
  using Range = Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>;
  dispatch_max_width(mlp.layout.widest, [&](auto width) {
    constexpr int W = decltype(width)::value;
    const impl::EvaluateWithJacobians<W, T, MemorySpace> pairs{mlp, X, codes, code_rates, g, F, dgdxhat, velocity};
    if constexpr (impl::evaluate_in_blocks<ExecutionSpace>) {
      const long blocks = (n + host_block_lanes - 1) / host_block_lanes;
      Kokkos::parallel_for("mpmrom::nn::evaluate_with_jacobians", Range(space, 0, blocks),
                           impl::EvaluateWithJacobiansBlocks<W, T, MemorySpace>{pairs});
    } else {
      Kokkos::parallel_for("mpmrom::nn::evaluate_with_jacobians", Range(space, 0, n), pairs);
    }
  });
}

}  // namespace mpmrom::nn
