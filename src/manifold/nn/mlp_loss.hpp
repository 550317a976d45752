// The training loss of the deformation map (src/manifold/nn/mlp_train.hpp): which forward channels a minibatch
// carries, the samples' targets, and loss (7) of the paper plus the affine term, with its adjoint with respect to the
// network outputs.
#pragma once

#include <Kokkos_Core.hpp>

#include "core/kokkos_compat.hpp"
#include "manifold/nn/mlp.hpp"

namespace mpmrom::nn {

inline constexpr int max_channels = 8;

// Which forward tangents a minibatch carries.
struct Channels {
  int count = 1;
  int gradient = -1;  // first of the three d/dX channels, -1 when lambda1 = 0
  int velocity = -1;  // the d/dxhat * xhatdot channel, -1 when lambda2 = 0
  int affine = -1;    // first of the three d2/(dX_j dxhatdot) channels, -1 when lambda3 = 0 (they need both above)

  static Channels make(bool with_gradient, bool with_velocity, bool with_affine = false) {
    Channels c;
    with_gradient = with_gradient || with_affine;
    with_velocity = with_velocity || with_affine;
    if (with_gradient) {
      c.gradient = c.count;
      c.count += 3;
    }
    if (with_velocity) c.velocity = c.count++;
    if (with_affine) {
      c.affine = c.count;
      c.count += 3;
    }
    return c;
  }
  // j of a mixed channel c (d2/(dX_j dxhatdot)), -1 for the others.
  KOKKOS_INLINE_FUNCTION int mixed_index(int c) const { return affine >= 0 && c >= affine ? c - affine : -1; }
};

// Loss (7), each term made dimensionless by the training data's own scale (RMS displacement, RMS of F - I, RMS
// velocity, RMS of C F), so the lambdas weigh relative errors and do not depend on the scene's units:
//   loss = mean over samples of |g - x|^2 / (3 sx^2) + lambda1 |dg/dX - F|^2 / (9 sF^2)
//                                + lambda2 |dg/dxhat xhatdot - v|^2 / (3 sv^2) + lambda3 |Fdot - C F|^2 / (9 sA^2),
// the last (not the paper's) asking the manifold's velocity gradient Fdot F^-1 to be the full-order run's APIC
// matrix C, which the reduced model's particle-to-grid transfer hands the grid as affine momentum m C.
template <class T>
struct LossWeights {
  T lambda_gradient = 0;
  T lambda_velocity = 0;
  T lambda_affine = 0;
  T position_scale = 1;
  T gradient_scale = 1;
  T velocity_scale = 1;
  T affine_scale = 1;
};

// The four mean terms (before the lambdas) of the loss over a set of samples.
template <class T>
struct LossTerms {
  T position = 0, gradient = 0, velocity = 0, affine = 0;
  KOKKOS_INLINE_FUNCTION LossTerms& operator+=(const LossTerms& o) {
    position += o.position;
    gradient += o.gradient;
    velocity += o.velocity;
    affine += o.affine;
    return *this;
  }
};

template <class T, class MemorySpace>
using Activations = Kokkos::View<T***, Kokkos::LayoutRight, MemorySpace>;  // (samples, channels, units)

// Where a minibatch's samples come from and what they must match.
template <class T, class MemorySpace>
struct BatchSamples {
  int samples_per_snapshot = 1;
  Kokkos::View<const int*, MemorySpace> point;     // (samples): material point index
  Kokkos::View<const int*, MemorySpace> snapshot;  // (batch snapshots): global snapshot index (its code)
  Kokkos::View<const int*, MemorySpace> row;       // (batch snapshots): its row in x, F and v
  // Samples the loss averages over: 0 for this minibatch's own; under data-parallel training, the whole minibatch's
  // over every rank, so that the ranks' gradients sum to the whole minibatch's.
  long total_samples = 0;
  PointsView<T, MemorySpace> X;                                   // (points, 3) reference positions
  Kokkos::View<const T***, Kokkos::LayoutRight, MemorySpace> x;   // (snapshots, points, 3) target positions
  Kokkos::View<const T***, Kokkos::LayoutRight, MemorySpace> F;   // (snapshots, points, 9) target F, row-major
  Kokkos::View<const T***, Kokkos::LayoutRight, MemorySpace> v;   // (snapshots, points, 3) target velocities
  Kokkos::View<const T***, Kokkos::LayoutRight, MemorySpace> CF;  // (snapshots, points, 9) target C F (lambda3 > 0)
};

namespace impl {

// The loss per sample, reduced into its four terms (an array reduction: one pass, works in Kokkos 3.4 and 4.x).
template <class T, class MemorySpace>
struct LossAndOutputAdjoint {
  using value_type = T[];
  using size_type = int;
  unsigned value_count = 4;

  Standardization<T> s;
  Channels channels;
  BatchSamples<T, MemorySpace> batch;
  Activations<T, MemorySpace> Y, Ybar;
  T wx, wF, wv, wA;                              // 1 / (components * scale^2) of each term
  T adjoint_x, adjoint_F, adjoint_v, adjoint_A;  // d(loss)/d(term sum) of each term, lambdas and 1 / samples folded in

  KOKKOS_INLINE_FUNCTION void init(value_type sums) const {
    for (unsigned i = 0; i < value_count; ++i) sums[i] = T(0);
  }
  KOKKOS_INLINE_FUNCTION void join(MPMROM_REDUCTION_VOLATILE value_type dst,
                                   const MPMROM_REDUCTION_VOLATILE value_type src) const {
    for (unsigned i = 0; i < value_count; ++i) dst[i] += src[i];
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int b, value_type sums) const {
    const bool with_adjoint = Ybar.extent(0) > 0;
    const int p = batch.point(b), t = batch.row(b / batch.samples_per_snapshot);
    for (int k = 0; k < 3; ++k) {
      const T g = batch.X(p, k) + s.output_mean[k] + s.output_scale[k] * Y(b, 0, k);
      const T res = g - batch.x(t, p, k);
      sums[0] += wx * res * res;
      if (with_adjoint) Ybar(b, 0, k) = adjoint_x * 2 * wx * res * s.output_scale[k];
    }
    if (channels.gradient >= 0) {
      for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d) {
          const T Fkd = (k == d ? T(1) : T(0)) + s.output_scale[k] * Y(b, channels.gradient + d, k);
          const T res = Fkd - batch.F(t, p, 3 * k + d);
          sums[1] += wF * res * res;
          if (with_adjoint) Ybar(b, channels.gradient + d, k) = adjoint_F * 2 * wF * res * s.output_scale[k];
        }
    }
    if (channels.velocity >= 0) {
      for (int k = 0; k < 3; ++k) {
        const T res = s.output_scale[k] * Y(b, channels.velocity, k) - batch.v(t, p, k);
        sums[2] += wv * res * res;
        if (with_adjoint) Ybar(b, channels.velocity, k) = adjoint_v * 2 * wv * res * s.output_scale[k];
      }
    }
    if (channels.affine >= 0) {
      for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d) {
          const T res = s.output_scale[k] * Y(b, channels.affine + d, k) - batch.CF(t, p, 3 * k + d);
          sums[3] += wA * res * res;
          if (with_adjoint) Ybar(b, channels.affine + d, k) = adjoint_A * 2 * wA * res * s.output_scale[k];
        }
    }
  }
};

}  // namespace impl

// The loss from the network outputs Y (samples, channels, 3): returns the mean terms and, when Ybar is not empty,
// writes dloss/dY into it (loss = position + lambda1 gradient + lambda2 velocity + lambda3 affine terms, averaged
// over samples; over batch.total_samples when set, of which this minibatch is a part).
template <class ExecutionSpace, class T, class MemorySpace>
LossTerms<T> loss_and_output_adjoint(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp,
                                     const Channels channels, const LossWeights<T> weights,
                                     const BatchSamples<T, MemorySpace>& batch, const Activations<T, MemorySpace>& Y,
                                     const Activations<T, MemorySpace>& Ybar) {
  const int num_samples = int(Y.extent(0));
  const T inv_n = T(1) / T(batch.total_samples > 0 ? batch.total_samples : num_samples);
  impl::LossAndOutputAdjoint<T, MemorySpace> functor;
  functor.s = mlp.standardization;
  functor.channels = channels;
  functor.batch = batch;
  functor.Y = Y;
  functor.Ybar = Ybar;
  functor.wx = T(1) / (3 * weights.position_scale * weights.position_scale);
  functor.wF = T(1) / (9 * weights.gradient_scale * weights.gradient_scale);
  functor.wv = T(1) / (3 * weights.velocity_scale * weights.velocity_scale);
  functor.wA = T(1) / (9 * weights.affine_scale * weights.affine_scale);
  functor.adjoint_x = inv_n;
  functor.adjoint_F = inv_n * weights.lambda_gradient;
  functor.adjoint_v = inv_n * weights.lambda_velocity;
  functor.adjoint_A = inv_n * weights.lambda_affine;
  T sums[4] = {0, 0, 0, 0};
  Kokkos::parallel_reduce("mpmrom::nn::train::loss", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples),
                          functor, sums);
  space.fence();
  return LossTerms<T>{sums[0] * inv_n, sums[1] * inv_n, sums[2] * inv_n, sums[3] * inv_n};
}

}  // namespace mpmrom::nn
