// g(X; xhat) and dg/dxhat of a narrow network (every layer, and 3 + r, at most register_width wide) with one thread
// a point and every activation in registers: the layers zero-padded to register_width x register_width, so that
// every loop over neurons has a compile-time trip count and unrolls, and the weights read four at a time (one
// aligned WeightQuad), the same for every thread of a warp (a broadcast). On GPUs this is what a large batch of
// narrow-network points wants: the team kernels (mlp_team.hpp) spread one point over a thread's lanes and pay a
// team barrier and shared-memory loads for every layer, which leaves them far from the arithmetic's bound. The sums
// run in SerialMlpForwardJacobian's order; the padding adds exact zeros to them.
#pragma once

#include <Kokkos_Core.hpp>

#include <cstddef>
#include <vector>

#include "core/math/unroll.hpp"
#include "manifold/nn/mlp.hpp"

namespace mpmrom::nn {

inline constexpr int register_width = 16;

// Four consecutive parameters, read as one aligned load.
template <class T>
struct alignas(4 * sizeof(T)) WeightQuad {
  T v[4];
};

// Where layer l sits in the padded parameters: W_l(i, j) at l * register_layer_values + i * register_width + j, then
// b_l(i) at l * register_layer_values + register_width^2 + i; a whole number of quads a layer.
inline constexpr int register_layer_values = register_width * register_width + register_width;
static_assert(register_layer_values % 4 == 0, "a layer is a whole number of quads");

template <class T, class MemorySpace>
struct RegisterMlp {
  int num_layers = 0;
  int latent_dim = 0;
  Standardization<T> standardization;
  Kokkos::View<const WeightQuad<T>*, MemorySpace> quads;  // num_layers * register_layer_values / 4; empty: not set

  static bool fits(const MlpLayout& layout) { return layout.widest <= register_width; }
};

// The parameters (MlpLayout order) padded as RegisterMlp says; the padding is zero.
template <class T, class Source>
std::vector<T> arrange_for_registers(const MlpLayout& layout, const Source& params) {
  std::vector<T> values(std::size_t(layout.num_layers) * register_layer_values, T(0));
  for (int l = 0; l < layout.num_layers; ++l) {
    T* layer = values.data() + std::size_t(l) * register_layer_values;
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      for (int j = 0; j < layout.dims[l]; ++j)
        layer[i * register_width + j] = T(params[std::size_t(layout.weight_offset[l] + i * layout.dims[l] + j)]);
      layer[register_width * register_width + i] = T(params[std::size_t(layout.bias_offset[l] + i)]);
    }
  }
  return values;
}

// g (3) and dg/dxhat (3 x r, row-major at dgdxhat) for one point: one forward pass and three reverse sweeps over the
// stored ELU slopes. Parallelism contract: one thread, no team, no scratch; RegisterMlp::fits(the network). A padded
// neuron has a zero pre-activation, so its activation is zero and it feeds zero products into the next layer.
template <class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void RegisterMlpPositionAndTangent(const RegisterMlp<T, MemorySpace>& net, const T X[3],
                                                          const T* xhat, T g[3], T* dgdxhat) {
  constexpr int W = register_width, quads_per_row = W / 4;
  const Standardization<T>& s = net.standardization;
  const int L = net.num_layers, r = net.latent_dim;
  T slope[max_layers - 1][W];  // indexed by the layer at run time: in local memory, written once and read once
  T h[W];
  for (int d = 0; d < 3; ++d) h[d] = (X[d] - s.input_mean[d]) / s.input_scale[d];
  for (int j = 3; j < W; ++j) h[j] = j - 3 < r ? xhat[j - 3] : T(0);
  for (int l = 0; l < L; ++l) {
    const WeightQuad<T>* layer = net.quads.data() + l * (register_layer_values / 4);
    T a[W];
    for (int q = 0; q < quads_per_row; ++q) {
      const WeightQuad<T> bias = layer[W * quads_per_row + q];
      for (int c = 0; c < 4; ++c) a[4 * q + c] = bias.v[c];
    }
    MPMROM_UNROLL
    for (int i = 0; i < W; ++i)
      for (int q = 0; q < quads_per_row; ++q) {
        const WeightQuad<T> w = layer[i * quads_per_row + q];
        for (int c = 0; c < 4; ++c) a[i] += w.v[c] * h[4 * q + c];
      }
    if (l + 1 < L) {
      for (int i = 0; i < W; ++i) elu_and_derivative(a[i], h[i], slope[l][i]);
    } else {
      for (int i = 0; i < W; ++i) h[i] = a[i];
    }
  }
  for (int k = 0; k < 3; ++k) g[k] = X[k] + s.output_mean[k] + s.output_scale[k] * h[k];

  // adjoint[k][j] = dy_k / d(input j of the layer), the three outputs' sweeps at once
  T adjoint[3][W];
  {
    const WeightQuad<T>* last = net.quads.data() + (L - 1) * (register_layer_values / 4);
    for (int k = 0; k < 3; ++k)
      for (int q = 0; q < quads_per_row; ++q) {
        const WeightQuad<T> w = last[k * quads_per_row + q];
        for (int c = 0; c < 4; ++c) adjoint[k][4 * q + c] = w.v[c];
      }
  }
  for (int l = L - 2; l >= 0; --l) {
    const WeightQuad<T>* layer = net.quads.data() + l * (register_layer_values / 4);
    T below[3][W];
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < W; ++j) {
        adjoint[k][j] *= slope[l][j];
        below[k][j] = T(0);
      }
    MPMROM_UNROLL
    for (int i = 0; i < W; ++i)
      for (int q = 0; q < quads_per_row; ++q) {
        const WeightQuad<T> w = layer[i * quads_per_row + q];
        for (int c = 0; c < 4; ++c)
          for (int k = 0; k < 3; ++k) below[k][4 * q + c] += w.v[c] * adjoint[k][i];
      }
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < W; ++j) adjoint[k][j] = below[k][j];
  }
  for (int k = 0; k < 3; ++k)
    for (int j = 3; j < W; ++j)
      if (j - 3 < r) dgdxhat[k * r + j - 3] = s.output_scale[k] * adjoint[k][j];
}

}  // namespace mpmrom::nn
