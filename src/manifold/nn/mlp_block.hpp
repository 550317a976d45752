// The one-thread network kernels of mlp.hpp for a block of points at once, for CPUs: the activations of Lanes
// points sit side by side ([neuron][lane]), so that each weight is read once for the block and every multiply-add
// runs across the lanes, which the compiler vectorises. One point a thread (SerialMlpForwardJacobian) spends its
// time in a dependent chain of scalar multiply-adds per neuron; here the chain is the same for each lane (the same
// sums in the same order; the compiler may fuse a multiply-add in one kernel and not in the other, so the two agree
// to rounding) and the lanes hide its latency. 8 lanes of double ran the poke model's (5 layers of 48) g and dg/dxhat
// 3x faster than one point a thread on one core. For host memory only (math::host_lane_blocks): on GPUs a thread's
// arrays would spill to local memory.
#pragma once

#include "core/math/simd.hpp"
#include "core/math/unroll.hpp"
#include "manifold/nn/mlp.hpp"
#include "manifold/nn/mlp_kinematics.hpp"

namespace mpmrom::nn {

// Lanes a CPU block takes: two AVX2 vectors of double, one of float.
inline constexpr int host_block_lanes = 8;

// The points of one block: X (Lanes, 3) and each lane's latent state.
template <int Lanes, class T>
struct PointBlock {
  T X[Lanes][3];
  const T* xhat[Lanes];
};

namespace impl {

// The standardised inputs (3 + r, Lanes) of a block.
template <int Lanes, int MaxWidth, class T>
KOKKOS_INLINE_FUNCTION void block_inputs(const Standardization<T>& s, int r, const PointBlock<Lanes, T>& points,
                                         T (*h)[Lanes]) {
  for (int d = 0; d < 3; ++d)
    for (int p = 0; p < Lanes; ++p) h[d][p] = (points.X[p][d] - s.input_mean[d]) / s.input_scale[d];
  for (int q = 0; q < r; ++q)
    for (int p = 0; p < Lanes; ++p) h[3 + q][p] = points.xhat[p][q];
}

// One affine layer's pre-activations a(i, lane) = b_i + sum_j W_l(i, j) h(j, lane), j ascending as in the one-point
// kernels.
template <int Lanes, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void block_affine(const Mlp<T, MemorySpace>& mlp, int l, int i, const T (*h)[Lanes],
                                         T (&a)[Lanes]) {
  const T bias = mlp.bias(l, i);
  for (int p = 0; p < Lanes; ++p) a[p] = bias;
  const int n_in = mlp.layout.dims[l];
  const T* W = &mlp.params(mlp.layout.weight_offset[l] + i * n_in);
  for (int j = 0; j < n_in; ++j) {
    const T w = W[j];
    MPMROM_SIMD
    for (int p = 0; p < Lanes; ++p) a[p] += w * h[j][p];
  }
}

// dy_k / dz (k < 3, z the standardised input; [k][input][lane]) from the hidden layers' slopes:
// SerialMlpOutputAdjoint's reverse sweeps for the three outputs together, each sum over i ascending from zero as there.
// Uses the two buffers and returns the one holding the result.
template <int Lanes, int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION auto block_output_adjoints(const Mlp<T, MemorySpace>& mlp, const T (*slope)[MaxWidth][Lanes],
                                                  T (*adjoint)[MaxWidth][Lanes], T (*spare)[MaxWidth][Lanes]) {
  const MlpLayout& layout = mlp.layout;
  const int L = layout.num_layers;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < layout.dims[L - 1]; ++j) {
      const T w = mlp.weight(L - 1, k, j);
      for (int p = 0; p < Lanes; ++p) adjoint[k][j][p] = w;
    }
  T(*up)[MaxWidth][Lanes] = adjoint;
  T(*down)[MaxWidth][Lanes] = spare;
  for (int l = L - 2; l >= 0; --l) {
    const int n_in = layout.dims[l], n_out = layout.dims[l + 1];
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < n_out; ++i)
        for (int p = 0; p < Lanes; ++p) up[k][i][p] *= slope[l][i][p];
    for (int j = 0; j < n_in; ++j) {
      T sum[3][Lanes];
      for (int k = 0; k < 3; ++k)
        for (int p = 0; p < Lanes; ++p) sum[k][p] = T(0);
      for (int i = 0; i < n_out; ++i) {
        const T w = mlp.weight(l, i, j);
        for (int k = 0; k < 3; ++k) {
          MPMROM_SIMD
          for (int p = 0; p < Lanes; ++p) sum[k][p] += w * up[k][i][p];
        }
      }
      for (int k = 0; k < 3; ++k)
        for (int p = 0; p < Lanes; ++p) down[k][j][p] = sum[k][p];
    }
    T(*tmp)[MaxWidth][Lanes] = up;
    up = down;
    down = tmp;
  }
  return up;
}

}  // namespace impl

// g(X; xhat) of each point of the block, as SerialMlpForward. Parallelism contract: one thread, no team, no scratch;
// MaxWidth >= layout.widest.
template <int Lanes, int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void BlockMlpForward(const Mlp<T, MemorySpace>& mlp, const PointBlock<Lanes, T>& points,
                                            T (*g)[3]) {
  const MlpLayout& layout = mlp.layout;
  const Standardization<T>& s = mlp.standardization;
  T buffer[2][MaxWidth][Lanes];
  T(*h)[Lanes] = buffer[0];
  T(*next)[Lanes] = buffer[1];
  impl::block_inputs<Lanes, MaxWidth>(s, layout.latent_dim, points, h);
  for (int l = 0; l < layout.num_layers; ++l) {
    const bool hidden = l + 1 < layout.num_layers;
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      T a[Lanes];
      impl::block_affine(mlp, l, i, h, a);
      for (int p = 0; p < Lanes; ++p) next[i][p] = hidden ? elu(a[p]) : a[p];
    }
    T(*tmp)[Lanes] = h;
    h = next;
    next = tmp;
  }
  for (int p = 0; p < Lanes; ++p)
    for (int k = 0; k < 3; ++k) g[p][k] = points.X[p][k] + s.output_mean[k] + s.output_scale[k] * h[k][p];
}

// g, F = dg/dX and dg/dxhat (3 x r row-major at dgdxhat[lane]) of each point of the block, as
// SerialMlpForwardJacobian: one forward pass, then the three outputs' reverse sweeps together. F may be null.
// Parallelism contract: one thread, no team, no scratch; MaxWidth >= layout.widest.
template <int Lanes, int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void BlockMlpForwardJacobian(const Mlp<T, MemorySpace>& mlp, const PointBlock<Lanes, T>& points,
                                                    T (*g)[3], T (*F)[3][3], T* const* dgdxhat) {
  const MlpLayout& layout = mlp.layout;
  const Standardization<T>& s = mlp.standardization;
  const int L = layout.num_layers, r = layout.latent_dim;
  T slope[max_layers - 1][MaxWidth][Lanes];  // elu'(a) of each hidden layer
  T buffer[2][MaxWidth][Lanes];
  T(*h)[Lanes] = buffer[0];
  T(*next)[Lanes] = buffer[1];
  impl::block_inputs<Lanes, MaxWidth>(s, r, points, h);
  for (int l = 0; l < L; ++l) {
    const bool hidden = l + 1 < L;
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      T a[Lanes];
      impl::block_affine(mlp, l, i, h, a);
      if (hidden) {
        for (int p = 0; p < Lanes; ++p) elu_and_derivative(a[p], next[i][p], slope[l][i][p]);
      } else {
        for (int p = 0; p < Lanes; ++p) next[i][p] = a[p];
      }
    }
    T(*tmp)[Lanes] = h;
    h = next;
    next = tmp;
  }
  for (int p = 0; p < Lanes; ++p)
    for (int k = 0; k < 3; ++k) g[p][k] = points.X[p][k] + s.output_mean[k] + s.output_scale[k] * h[k][p];

  T adjoint[3][MaxWidth][Lanes], spare[3][MaxWidth][Lanes];
  const auto up = impl::block_output_adjoints<Lanes, MaxWidth>(mlp, slope, adjoint, spare);
  for (int p = 0; p < Lanes; ++p)
    for (int k = 0; k < 3; ++k) {
      if (F != nullptr)
        for (int d = 0; d < 3; ++d)
          F[p][k][d] = (k == d ? T(1) : T(0)) + s.output_scale[k] * up[k][d][p] / s.input_scale[d];
      for (int q = 0; q < r; ++q) dgdxhat[p][k * r + q] = s.output_scale[k] * up[k][3 + q][p];
    }
}

// The kinematics of SerialMlpKinematics (g, F, v, Fdot; dg/dxhat where the lane's dgdxhat is not null) for each point
// of the block at its latent state and rate: the eight forward channels of each neuron across the lanes, then, if any
// lane asks for dg/dxhat, the three reverse sweeps. Parallelism contract: one thread, no team, no scratch; MaxWidth >=
// layout.widest.
template <int Lanes, int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void BlockMlpKinematics(const Mlp<T, MemorySpace>& mlp, const PointBlock<Lanes, T>& points,
                                               const T* const* xhatdot, PointKinematics<T>* out, T* const* dgdxhat) {
  constexpr int C = kinematics_channels;
  const MlpLayout& layout = mlp.layout;
  const Standardization<T>& s = mlp.standardization;
  const int L = layout.num_layers, r = layout.latent_dim;
  T slope[max_layers - 1][MaxWidth][Lanes];
  T buffer[2][MaxWidth][C][Lanes];
  T(*h)[C][Lanes] = buffer[0];
  T(*next)[C][Lanes] = buffer[1];
  for (int j = 0; j < 3 + r; ++j)
    for (int c = 0; c < C; ++c)
      for (int p = 0; p < Lanes; ++p) h[j][c][p] = T(0);
  for (int p = 0; p < Lanes; ++p) {
    for (int d = 0; d < 3; ++d) {
      h[d][0][p] = (points.X[p][d] - s.input_mean[d]) / s.input_scale[d];
      h[d][1 + d][p] = T(1) / s.input_scale[d];
    }
    for (int q = 0; q < r; ++q) {
      h[3 + q][0][p] = points.xhat[p][q];
      h[3 + q][4][p] = xhatdot[p][q];
    }
  }
  for (int l = 0; l < L; ++l) {
    const bool hidden = l + 1 < L;
    const int n_in = layout.dims[l];
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      T a[C][Lanes];
      for (int c = 0; c < C; ++c)
        for (int p = 0; p < Lanes; ++p) a[c][p] = c == 0 ? mlp.bias(l, i) : T(0);
      const T* W = &mlp.params(layout.weight_offset[l] + i * n_in);
      for (int half = 0; half < C; half += C / 2) {  // four channels' accumulators at a time, held in registers
        T sum[C / 2][Lanes];
        for (int c = 0; c < C / 2; ++c)
          for (int p = 0; p < Lanes; ++p) sum[c][p] = a[half + c][p];
        for (int j = 0; j < n_in; ++j) {
          const T w = W[j];
          MPMROM_UNROLL
          for (int c = 0; c < C / 2; ++c) {
            MPMROM_SIMD
            for (int p = 0; p < Lanes; ++p) sum[c][p] += w * h[j][half + c][p];
          }
        }
        for (int c = 0; c < C / 2; ++c)
          for (int p = 0; p < Lanes; ++p) a[half + c][p] = sum[c][p];
      }
      for (int p = 0; p < Lanes; ++p) {
        T lane[C];
        for (int c = 0; c < C; ++c) lane[c] = a[c][p];
        NeuronChannels<T> z;
        finish_neuron(lane, hidden, z, hidden ? &slope[l][i][p] : nullptr);
        for (int c = 0; c < C; ++c) next[i][c][p] = z.c[c];
      }
    }
    T(*tmp)[C][Lanes] = h;
    h = next;
    next = tmp;
  }
  bool any_jacobian = false;
  for (int p = 0; p < Lanes; ++p) {
    any_jacobian = any_jacobian || dgdxhat[p] != nullptr;
    for (int k = 0; k < 3; ++k) {
      out[p].g[k] = points.X[p][k] + s.output_mean[k] + s.output_scale[k] * h[k][0][p];
      out[p].v[k] = s.output_scale[k] * h[k][4][p];
      for (int j = 0; j < 3; ++j) {
        out[p].F[k][j] = (k == j ? T(1) : T(0)) + s.output_scale[k] * h[k][1 + j][p];
        out[p].Fdot[k][j] = s.output_scale[k] * h[k][5 + j][p];
      }
    }
  }
  if (!any_jacobian) return;
  T adjoint[3][MaxWidth][Lanes], spare[3][MaxWidth][Lanes];
  const auto up = impl::block_output_adjoints<Lanes, MaxWidth>(mlp, slope, adjoint, spare);
  for (int p = 0; p < Lanes; ++p)
    if (dgdxhat[p] != nullptr)
      for (int k = 0; k < 3; ++k)
        for (int q = 0; q < r; ++q) dgdxhat[p][k * r + q] = s.output_scale[k] * up[k][3 + q][p];
}

}  // namespace mpmrom::nn
