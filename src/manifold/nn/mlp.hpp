// The deformation map x = g(X; xhat) of the paper (equations 3-6) as a multi-layer perceptron, and its evaluation
// with Jacobians at one point by one thread (mlp_batch.hpp runs it over points and codes).
//
// Network: z = [(X - input_mean) / input_scale, xhat] (3 + r inputs) -> depth affine layers, ELU after every one but
// the last -> y (3 outputs), and g(X; xhat) = X + output_mean + output_scale * y: the network predicts the
// standardised displacement, so an untrained network is already close to the identity map and every output has
// unit scale whatever the size of the motion.
//
// Parameters: one flat array, layer by layer: W_l (dims[l+1] x dims[l], row-major) then b_l (dims[l+1]). Row-major
// weights give contiguous rows for the dot products of the forward pass on CPU and a broadcast read across a GPU
// warp (every thread of a warp reads the same weight).
#pragma once

#include <Kokkos_Core.hpp>

#include <type_traits>

#include "manifold/nn/activation.hpp"
#include "mpmrom/network.hpp"

namespace mpmrom::nn {

// What a kernel needs of a model: its layout, standardisation and parameters (first layout.num_params entries of
// params; the trainer keeps the latent codes after them in the same array).
template <class T, class MemorySpace>
struct Mlp {
  MlpLayout layout;
  Standardization<T> standardization;
  Kokkos::View<const T*, MemorySpace> params;

  KOKKOS_INLINE_FUNCTION T weight(int l, int i, int j) const {
    return params(layout.weight_offset[l] + i * layout.dims[l] + j);
  }
  KOKKOS_INLINE_FUNCTION T bias(int l, int i) const { return params(layout.bias_offset[l] + i); }
};

// g(X; xhat) for one (X, xhat) pair. Parallelism contract: one thread, no team, no scratch; MaxWidth >=
// layout.widest. xhat points at r contiguous values.
template <int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void SerialMlpForward(const Mlp<T, MemorySpace>& mlp, const T X[3], const T* xhat, T g[3]) {
  const MlpLayout& layout = mlp.layout;
  const Standardization<T>& s = mlp.standardization;
  T buffer[2][MaxWidth];
  T* h = buffer[0];
  T* next = buffer[1];
  for (int d = 0; d < 3; ++d) h[d] = (X[d] - s.input_mean[d]) / s.input_scale[d];
  for (int q = 0; q < layout.latent_dim; ++q) h[3 + q] = xhat[q];
  for (int l = 0; l < layout.num_layers; ++l) {
    const bool hidden = l + 1 < layout.num_layers;
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      T a = mlp.bias(l, i);
      for (int j = 0; j < layout.dims[l]; ++j) a += mlp.weight(l, i, j) * h[j];
      next[i] = hidden ? elu(a) : a;
    }
    T* tmp = h;
    h = next;
    next = tmp;
  }
  for (int k = 0; k < 3; ++k) g[k] = X[k] + s.output_mean[k] + s.output_scale[k] * h[k];
}

// Reverse sweep for output k over the ELU slopes of a forward pass: dy_k/dz, z the standardised input. Uses the two
// MaxWidth buffers and returns the one holding the result. Parallelism contract: one thread, no team, no scratch.
template <int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION T* SerialMlpOutputAdjoint(const Mlp<T, MemorySpace>& mlp, const T (*slope)[MaxWidth], int k,
                                                 T* adjoint, T* spare) {
  const MlpLayout& layout = mlp.layout;
  const int L = layout.num_layers;
  // adjoint of layer L-1's input for the output y_k: row k of W_{L-1}
  for (int j = 0; j < layout.dims[L - 1]; ++j) adjoint[j] = mlp.weight(L - 1, k, j);
  for (int l = L - 2; l >= 0; --l) {
    for (int i = 0; i < layout.dims[l + 1]; ++i) adjoint[i] *= slope[l][i];
    for (int j = 0; j < layout.dims[l]; ++j) spare[j] = T(0);
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      const T a = adjoint[i];
      for (int j = 0; j < layout.dims[l]; ++j) spare[j] += mlp.weight(l, i, j) * a;
    }
    T* tmp = adjoint;
    adjoint = spare;
    spare = tmp;
  }
  return adjoint;
}

// g(X; xhat), F = dg/dX (3x3, F[i][j] = dg_i/dX_j) and dg/dxhat (3 x r, row-major at dgdxhat) for one pair. The
// Jacobian comes from three reverse sweeps (one per output) over the stored ELU slopes: 4 matrix-vector products
// in all, against 4 + r for forward tangents. Parallelism contract: one thread, no team, no scratch;
// MaxWidth >= layout.widest.
template <int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void SerialMlpForwardJacobian(const Mlp<T, MemorySpace>& mlp, const T X[3], const T* xhat,
                                                     T g[3], T F[3][3], T* dgdxhat) {
  const MlpLayout& layout = mlp.layout;
  const Standardization<T>& s = mlp.standardization;
  const int L = layout.num_layers;
  T slope[max_layers - 1][MaxWidth];  // elu'(a) of each hidden layer
  T buffer[2][MaxWidth];
  T* h = buffer[0];
  T* next = buffer[1];
  for (int d = 0; d < 3; ++d) h[d] = (X[d] - s.input_mean[d]) / s.input_scale[d];
  for (int q = 0; q < layout.latent_dim; ++q) h[3 + q] = xhat[q];
  for (int l = 0; l < L; ++l) {
    const bool hidden = l + 1 < L;
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      T a = mlp.bias(l, i);
      for (int j = 0; j < layout.dims[l]; ++j) a += mlp.weight(l, i, j) * h[j];
      if (hidden)
        elu_and_derivative(a, next[i], slope[l][i]);
      else
        next[i] = a;
    }
    T* tmp = h;
    h = next;
    next = tmp;
  }
  for (int k = 0; k < 3; ++k) g[k] = X[k] + s.output_mean[k] + s.output_scale[k] * h[k];

  for (int k = 0; k < 3; ++k) {
    const T* dydz = SerialMlpOutputAdjoint<MaxWidth>(mlp, slope, k, h, next);
    // undo the standardisation
    for (int d = 0; d < 3; ++d) F[k][d] = (k == d ? T(1) : T(0)) + s.output_scale[k] * dydz[d] / s.input_scale[d];
    for (int q = 0; q < layout.latent_dim; ++q) dgdxhat[k * layout.latent_dim + q] = s.output_scale[k] * dydz[3 + q];
  }
}

// Calls f(std::integral_constant<int, W>{}) with the smallest compiled register width W >= widest.
template <class Functor>
void dispatch_max_width(int widest, Functor&& f) {
  if (widest <= 32)
    f(std::integral_constant<int, 32>{});
  else if (widest <= 64)
    f(std::integral_constant<int, 64>{});
  else if (widest <= max_width)
    f(std::integral_constant<int, max_width>{});
  else
    throw std::invalid_argument("network wider than " + std::to_string(max_width));
}

template <class T, class MemorySpace>
using PointsView = Kokkos::View<const T**, Kokkos::LayoutRight, MemorySpace>;  // (points, 3)
template <class T, class MemorySpace>
using CodesView = Kokkos::View<const T**, Kokkos::LayoutRight, MemorySpace>;  // (codes, r)

}  // namespace mpmrom::nn
