// The kinematics the reduced-order model needs from the deformation map at one material point (paper, equations
// 4-6): position g(X; xhat), deformation gradient F = dg/dX, velocity v = dg/dxhat xhatdot, the rate of the
// deformation gradient Fdot = d/dt F = (dF/dxhat) xhatdot (so that grad_x v = Fdot F^-1, APIC's affine matrix), and
// on request dg/dxhat itself (the tangent space the velocities are projected on).
//
// Forward mode with second-order channels: alongside the primal value it carries tangents along X_0..X_2, along
// xhatdot, and the mixed second derivatives d2/(dX_j dxhatdot), through each layer; dg/dxhat comes from three reverse
// sweeps over the stored ELU slopes, as in SerialMlpForwardJacobian.
#pragma once

#include "manifold/nn/mlp.hpp"

namespace mpmrom::nn {

template <class T>
struct PointKinematics {
  T g[3];
  T F[3][3];     // F[i][j] = dg_i / dX_j
  T v[3];        // dg/dxhat xhatdot
  T Fdot[3][3];  // d F / dt along xhatdot
};

// Channel layout of the forward sweep: 0 primal, 1-3 d/dX_j, 4 d/dxhatdot, 5-7 d2/(dX_j dxhatdot).
inline constexpr int kinematics_channels = 8;

// The eight channels of one neuron (kinematics_channels), read and written as one aligned block.
template <class T>
struct alignas(sizeof(T) * kinematics_channels) NeuronChannels {
  T c[kinematics_channels];
};

// A neuron's eight channels from its pre-activations: ELU with its tangents (hidden layers) or as they are (output),
// the slope kept in *slope for the reverse sweeps (hidden layers only).
template <class T>
KOKKOS_INLINE_FUNCTION void finish_neuron(const T (&a)[kinematics_channels], bool hidden, NeuronChannels<T>& z,
                                          T* slope) {
  if (!hidden) {
    for (int c = 0; c < kinematics_channels; ++c) z.c[c] = a[c];
    return;
  }
  T d1;
  elu_and_derivative(a[0], z.c[0], d1);
  const T d2 = a[0] > T(0) ? T(0) : d1;  // elu'' = elu' = exp(a) below zero: no second exp
  *slope = d1;
  for (int j = 0; j < 3; ++j) {
    z.c[1 + j] = d1 * a[1 + j];
    z.c[5 + j] = d2 * a[1 + j] * a[4] + d1 * a[5 + j];
  }
  z.c[4] = d1 * a[4];
}

// Parallelism contract: one thread, no team, no scratch; MaxWidth >= layout.widest. xhat and xhatdot point at r
// contiguous values; dgdxhat, if not null, receives the 3 x r Jacobian row-major.
template <int MaxWidth, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void SerialMlpKinematics(const Mlp<T, MemorySpace>& mlp, const T X[3], const T* xhat,
                                                const T* xhatdot, PointKinematics<T>& out, T* dgdxhat) {
  const MlpLayout& layout = mlp.layout;
  const Standardization<T>& s = mlp.standardization;
  const int L = layout.num_layers;
  const int r = layout.latent_dim;
  T slope[max_layers - 1][MaxWidth];  // elu'(a) of each hidden layer, for the reverse sweeps
  T buffer[2][kinematics_channels][MaxWidth];
  auto* h = buffer[0];
  auto* next = buffer[1];
  for (int c = 0; c < kinematics_channels; ++c)
    for (int j = 0; j < 3 + r; ++j) h[c][j] = T(0);
  for (int d = 0; d < 3; ++d) {
    h[0][d] = (X[d] - s.input_mean[d]) / s.input_scale[d];
    h[1 + d][d] = T(1) / s.input_scale[d];
  }
  for (int q = 0; q < r; ++q) {
    h[0][3 + q] = xhat[q];
    h[4][3 + q] = xhatdot[q];
  }
  for (int l = 0; l < L; ++l) {
    const bool hidden = l + 1 < L;
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      T a[kinematics_channels];
      a[0] = mlp.bias(l, i);
      for (int c = 1; c < kinematics_channels; ++c) a[c] = T(0);
      for (int j = 0; j < layout.dims[l]; ++j) {
        const T w = mlp.weight(l, i, j);
        for (int c = 0; c < kinematics_channels; ++c) a[c] += w * h[c][j];
      }
      NeuronChannels<T> z;
      finish_neuron(a, hidden, z, hidden ? &slope[l][i] : nullptr);
      for (int c = 0; c < kinematics_channels; ++c) next[c][i] = z.c[c];
    }
    auto* tmp = h;
    h = next;
    next = tmp;
  }
  for (int k = 0; k < 3; ++k) {
    out.g[k] = X[k] + s.output_mean[k] + s.output_scale[k] * h[0][k];
    out.v[k] = s.output_scale[k] * h[4][k];
    for (int j = 0; j < 3; ++j) {
      out.F[k][j] = (k == j ? T(1) : T(0)) + s.output_scale[k] * h[1 + j][k];
      out.Fdot[k][j] = s.output_scale[k] * h[5 + j][k];
    }
  }
  if (dgdxhat == nullptr) return;

  for (int k = 0; k < 3; ++k) {
    const T* dydz = SerialMlpOutputAdjoint<MaxWidth>(mlp, slope, k, buffer[0][0], buffer[1][0]);
    for (int q = 0; q < r; ++q) dgdxhat[k * r + q] = s.output_scale[k] * dydz[3 + q];
  }
}

}  // namespace mpmrom::nn
