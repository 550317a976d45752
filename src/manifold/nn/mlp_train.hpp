// Training kernels for the deformation map (src/manifold/nn/mlp.hpp): loss (7) of the paper and its gradient with
// respect to every weight and every latent code, for a minibatch of (snapshot, material point) samples.
//
// The minibatch goes through the network layer by layer (one kernel per layer, activations of all samples kept),
// carrying C channels per sample: channel 0 the primal values, then, when the loss needs them, three forward tangents
// along X (for dg/dX), one along the latent rate xhatdot (for dg/dxhat * xhatdot) and three mixed second derivatives
// d2/(dX_j dxhatdot) (for Fdot = dF/dxhat * xhatdot). The backward pass is reverse mode through all of them together.
// Every sum runs in a fixed order over a fixed partition of the minibatch: no atomics, so a given backend gives
// bit-identical gradients run after run.
//
// Activation views are (samples, channels, units), row-major. A minibatch holds `samples_per_snapshot` consecutive
// samples of each of its snapshots: sample b belongs to batch snapshot b / samples_per_snapshot.
#pragma once

#include <Kokkos_Core.hpp>

#include <vector>

#include "core/kokkos_compat.hpp"
#include "manifold/nn/activation.hpp"
#include "manifold/nn/mlp.hpp"
#include "manifold/nn/mlp_loss.hpp"

namespace mpmrom::nn {

// CPU backends take the row-wise variants of the layer kernels (one sample per thread, contiguous inner loops that
// vectorise without reassociating sums); GPU backends take one output entry per thread (coalesced, no local arrays).
template <class ExecutionSpace>
constexpr bool row_wise_kernels() {
  return Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible;
}

// Network input of every sample: [standardised X, xhat] on channel 0, e_d / input_scale_d on the X-tangent channels,
// [0, xhatdot] on the velocity channel. codes, rates: (batch snapshots, r).
template <class ExecutionSpace, class T, class MemorySpace>
void fill_inputs(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp, const Channels channels,
                 const BatchSamples<T, MemorySpace>& batch, const CodesView<T, MemorySpace>& codes,
                 const CodesView<T, MemorySpace>& rates, const Activations<T, MemorySpace>& H0) {
  const int num_samples = int(H0.extent(0));
  const int r = mlp.layout.latent_dim;
  const Standardization<T> s = mlp.standardization;
  const auto point = batch.point;
  const auto X = batch.X;
  const int per_snapshot = batch.samples_per_snapshot;
  Kokkos::parallel_for(
      "mpmrom::nn::train::inputs", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples),
      KOKKOS_LAMBDA(const int b) {
        const int p = point(b), snap = b / per_snapshot;
        for (int c = 0; c < channels.count; ++c)
          for (int j = 0; j < 3 + r; ++j) H0(b, c, j) = T(0);
        for (int d = 0; d < 3; ++d) H0(b, 0, d) = (X(p, d) - s.input_mean[d]) / s.input_scale[d];
        for (int q = 0; q < r; ++q) H0(b, 0, 3 + q) = codes(snap, q);
        if (channels.gradient >= 0)
          for (int d = 0; d < 3; ++d) H0(b, channels.gradient + d, d) = T(1) / s.input_scale[d];
        if (channels.velocity >= 0)
          for (int q = 0; q < r; ++q) H0(b, channels.velocity, 3 + q) = rates(snap, q);
      });
}

// Layer l forward for every sample and channel: A = W_l H (+ b_l on channel 0); for a hidden layer also
// H_next = elu(A) on channel 0 and elu'(A_0) * A_c on the tangent channels. For the output layer H_next is empty
// and A is the output y.
template <class ExecutionSpace, class T, class MemorySpace>
void layer_forward(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp, const int l, const Channels channels,
                   const Activations<T, MemorySpace>& H, const Activations<T, MemorySpace>& A,
                   const Activations<T, MemorySpace>& H_next,
                   const Kokkos::View<const T*, MemorySpace>& transposed_weights) {
  const int num_samples = int(H.extent(0));
  const int n_in = mlp.layout.dims[l], n_out = mlp.layout.dims[l + 1];
  const bool hidden = l + 1 < mlp.layout.num_layers;
  if constexpr (row_wise_kernels<ExecutionSpace>()) {
    // W_l^T (n_in x n_out) at the layer's weight offset: out += h_j * (row j of W^T), contiguous over the outputs
    const int w0 = mlp.layout.weight_offset[l];
    Kokkos::parallel_for(
        "mpmrom::nn::train::layer_forward", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples),
        KOKKOS_LAMBDA(const int b) {
          T acc[max_width], slope[max_width], curvature[max_width];
          for (int c = 0; c < channels.count; ++c) {
            for (int i = 0; i < n_out; ++i) acc[i] = c == 0 ? mlp.bias(l, i) : T(0);
            for (int j = 0; j < n_in; ++j) {
              const T h = H(b, c, j);
              const T* wt = &transposed_weights(w0 + j * n_out);
              for (int i = 0; i < n_out; ++i) acc[i] += h * wt[i];
            }
            for (int i = 0; i < n_out; ++i) A(b, c, i) = acc[i];
            if (!hidden) continue;
            if (c == 0) {
              for (int i = 0; i < n_out; ++i) {
                T value;
                elu_and_derivative(acc[i], value, slope[i]);
                curvature[i] = acc[i] > T(0) ? T(0) : slope[i];  // elu'' = elu' = exp(a) below zero
                H_next(b, 0, i) = value;
              }
            } else if (channels.mixed_index(c) < 0) {
              for (int i = 0; i < n_out; ++i) H_next(b, c, i) = slope[i] * acc[i];
            } else {  // d2 elu(a)/(dX_j dxhatdot) = elu' a_jv + elu'' a_j a_v (a_j, a_v written above)
              const int j = channels.gradient + channels.mixed_index(c);
              for (int i = 0; i < n_out; ++i)
                H_next(b, c, i) = slope[i] * acc[i] + curvature[i] * A(b, j, i) * A(b, channels.velocity, i);
            }
          }
        });
  } else {
    Kokkos::parallel_for(
        "mpmrom::nn::train::layer_forward", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples * n_out),
        KOKKOS_LAMBDA(const int e) {
          const int b = e / n_out, i = e % n_out;
          T acc[max_channels] = {};
          for (int j = 0; j < n_in; ++j) {
            const T w = mlp.weight(l, i, j);
            for (int c = 0; c < channels.count; ++c) acc[c] += w * H(b, c, j);
          }
          acc[0] += mlp.bias(l, i);
          for (int c = 0; c < channels.count; ++c) A(b, c, i) = acc[c];
          if (!hidden) return;
          T value, slope;
          elu_and_derivative(acc[0], value, slope);
          const T curvature = acc[0] > T(0) ? T(0) : slope;
          H_next(b, 0, i) = value;
          for (int c = 1; c < channels.count; ++c) {
            const int j = channels.mixed_index(c);
            H_next(b, c, i) = slope * acc[c];
            if (j >= 0) H_next(b, c, i) += curvature * acc[channels.gradient + j] * acc[channels.velocity];
          }
        });
  }
}

// Every layer's W^T at that layer's weight offset (biases untouched), for the row-wise forward kernel.
template <class ExecutionSpace, class T, class MemorySpace>
void transpose_weights(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp,
                       const Kokkos::View<T*, MemorySpace>& transposed) {
  const MlpLayout layout = mlp.layout;
  Kokkos::parallel_for(
      "mpmrom::nn::train::transpose_weights", Kokkos::RangePolicy<ExecutionSpace>(space, 0, layout.num_layers),
      KOKKOS_LAMBDA(const int l) {
        const int n_in = layout.dims[l], n_out = layout.dims[l + 1], w0 = layout.weight_offset[l];
        for (int i = 0; i < n_out; ++i)
          for (int j = 0; j < n_in; ++j) transposed(w0 + j * n_out + i) = mlp.weight(l, i, j);
      });
}

// Through a hidden layer's ELU, in place: Hbar (adjoint of the layer's output) becomes Abar (adjoint of its
// pre-activations). Channel 0: Hbar_0 elu'(A_0) + sum_c Hbar_c elu''(A_0) A_c + sum_j Hbar_jv elu'''(A_0) A_j A_v;
// tangent channels: Hbar_c elu'(A_0), plus, through each mixed channel jv = elu' A_jv + elu'' A_j A_v,
// Hbar_jv elu''(A_0) A_v on channel j and Hbar_jv elu''(A_0) A_j on channel v.
template <class ExecutionSpace, class T, class MemorySpace>
void activation_backward(const ExecutionSpace& space, const Channels channels, const Activations<T, MemorySpace>& A,
                         const Activations<T, MemorySpace>& Hbar) {
  const int num_samples = int(A.extent(0)), n = int(A.extent(2));
  Kokkos::parallel_for(
      "mpmrom::nn::train::activation_backward", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples * n),
      KOKKOS_LAMBDA(const int e) {
        const int b = e / n, i = e % n;
        const T a = A(b, 0, i);
        const T slope = elu_derivative(a), curvature = a > T(0) ? T(0) : slope;  // elu''' = elu'' = elu' for a <= 0
        T hbar[max_channels] = {};
        for (int c = 0; c < channels.count; ++c) hbar[c] = Hbar(b, c, i);
        T bar0 = hbar[0] * slope;
        for (int c = 1; c < channels.count; ++c) {
          bar0 += hbar[c] * curvature * A(b, c, i);
          Hbar(b, c, i) = hbar[c] * slope;
        }
        if (channels.affine >= 0) {
          const int v = channels.velocity;
          for (int j = 0; j < 3; ++j) {
            const int gj = channels.gradient + j;
            const T h = hbar[channels.affine + j] * curvature;
            bar0 += h * A(b, gj, i) * A(b, v, i);
            Hbar(b, gj, i) += h * A(b, v, i);
            Hbar(b, v, i) += h * A(b, gj, i);
          }
        }
        Hbar(b, 0, i) = bar0;
      });
}

// Samples per partial sum of the weight gradient: enough independent sums to fill a GPU or every CPU thread, few
// enough that the extra pass is cheap. Fixed per backend (not per thread count), so the summation order and the
// result never change.
template <class ExecutionSpace>
constexpr int weight_gradient_chunk() {
  return Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible ? 64 : 32;
}

// Layer l's weight and bias gradients, as partial sums over chunks of samples: partial(k, ...) for chunk k, at the
// layer's offsets in the parameter array. Abar: adjoint of the layer's pre-activations; H: the layer's input.
template <class ExecutionSpace, class T, class MemorySpace>
void weight_gradient_partials(const ExecutionSpace& space, const MlpLayout layout, const int l, const Channels channels,
                              const Activations<T, MemorySpace>& Abar, const Activations<T, MemorySpace>& H,
                              const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& partial) {
  const int num_samples = int(H.extent(0));
  const int chunk = weight_gradient_chunk<ExecutionSpace>();
  const int num_chunks = int(partial.extent(0));
  const int n_in = layout.dims[l], n_out = layout.dims[l + 1];
  const int w0 = layout.weight_offset[l], b0 = layout.bias_offset[l];
  const int per_chunk = n_out * (n_in + 1);  // n_in weights and one bias per output unit
  if constexpr (row_wise_kernels<ExecutionSpace>()) {
    // one chunk per thread, accumulated in place in its partial row (the layer's W is small enough for L1)
    Kokkos::parallel_for(
        "mpmrom::nn::train::weight_gradient", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_chunks),
        KOKKOS_LAMBDA(const int k) {
          const int end = (k + 1) * chunk < num_samples ? (k + 1) * chunk : num_samples;
          T* wbar = &partial(k, w0);
          T* bbar = &partial(k, b0);
          for (int i = 0; i < n_out * n_in; ++i) wbar[i] = T(0);
          for (int i = 0; i < n_out; ++i) bbar[i] = T(0);
          for (int b = k * chunk; b < end; ++b) {
            for (int i = 0; i < n_out; ++i) bbar[i] += Abar(b, 0, i);
            for (int c = 0; c < channels.count; ++c) {
              const T* h = &H(b, c, 0);
              for (int i = 0; i < n_out; ++i) {
                const T a = Abar(b, c, i);
                T* row = wbar + i * n_in;
                for (int j = 0; j < n_in; ++j) row[j] += a * h[j];
              }
            }
          }
        });
  } else {
    Kokkos::parallel_for(
        "mpmrom::nn::train::weight_gradient", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_chunks * per_chunk),
        KOKKOS_LAMBDA(const int e) {
          const int k = e / per_chunk, rest = e % per_chunk;
          const int i = rest / (n_in + 1), j = rest % (n_in + 1);
          const int end = (k + 1) * chunk < num_samples ? (k + 1) * chunk : num_samples;
          T acc = 0;
          if (j < n_in) {
            for (int b = k * chunk; b < end; ++b)
              for (int c = 0; c < channels.count; ++c) acc += Abar(b, c, i) * H(b, c, j);
            partial(k, w0 + i * n_in + j) = acc;
          } else {
            for (int b = k * chunk; b < end; ++b) acc += Abar(b, 0, i);
            partial(k, b0 + i) = acc;
          }
        });
  }
}

// grad(p) = sum over chunks of partial(k, p), for the network's parameters p < partial.extent(1).
template <class ExecutionSpace, class T, class MemorySpace>
void sum_partials(const ExecutionSpace& space, const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& partial,
                  const Kokkos::View<T*, MemorySpace>& grad) {
  const int num_chunks = int(partial.extent(0));
  Kokkos::parallel_for(
      "mpmrom::nn::train::sum_partials", Kokkos::RangePolicy<ExecutionSpace>(space, 0, int(partial.extent(1))),
      KOKKOS_LAMBDA(const int p) {
        T acc = 0;
        for (int k = 0; k < num_chunks; ++k) acc += partial(k, p);
        grad(p) = acc;
      });
}

// Adjoint of layer l's input: Hbar(b, c, j) = sum_i W_l(i, j) Abar(b, c, i).
template <class ExecutionSpace, class T, class MemorySpace>
void layer_input_adjoint(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp, const int l,
                         const Channels channels, const Activations<T, MemorySpace>& Abar,
                         const Activations<T, MemorySpace>& Hbar) {
  const int num_samples = int(Abar.extent(0));
  const int n_in = mlp.layout.dims[l], n_out = mlp.layout.dims[l + 1];
  if constexpr (row_wise_kernels<ExecutionSpace>()) {
    Kokkos::parallel_for(
        "mpmrom::nn::train::input_adjoint", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples),
        KOKKOS_LAMBDA(const int b) {
          T acc[max_width];
          for (int c = 0; c < channels.count; ++c) {
            for (int j = 0; j < n_in; ++j) acc[j] = T(0);
            for (int i = 0; i < n_out; ++i) {
              const T a = Abar(b, c, i);
              const T* w = &mlp.params(mlp.layout.weight_offset[l] + i * n_in);
              for (int j = 0; j < n_in; ++j) acc[j] += a * w[j];
            }
            for (int j = 0; j < n_in; ++j) Hbar(b, c, j) = acc[j];
          }
        });
  } else {
    Kokkos::parallel_for(
        "mpmrom::nn::train::input_adjoint", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_samples * n_in),
        KOKKOS_LAMBDA(const int e) {
          const int b = e / n_in, j = e % n_in;
          T acc[max_channels] = {};
          for (int i = 0; i < n_out; ++i) {
            const T w = mlp.weight(l, i, j);
            for (int c = 0; c < channels.count; ++c) acc[c] += w * Abar(b, c, i);
          }
          for (int c = 0; c < channels.count; ++c) Hbar(b, c, j) = acc[c];
        });
  }
}

// Per batch snapshot, the loss gradient with respect to its code (from channel 0) and to its code rate (from the
// velocity channel), summed over the snapshot's samples: code_grad, rate_grad (batch snapshots, r).
template <class ExecutionSpace, class T, class MemorySpace>
void code_adjoints(const ExecutionSpace& space, const Channels channels, const int samples_per_snapshot,
                   const Activations<T, MemorySpace>& Hbar0,
                   const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& code_grad,
                   const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& rate_grad) {
  const int num_snapshots = int(code_grad.extent(0)), r = int(code_grad.extent(1));
  Kokkos::parallel_for(
      "mpmrom::nn::train::code_adjoints", Kokkos::RangePolicy<ExecutionSpace>(space, 0, num_snapshots * r),
      KOKKOS_LAMBDA(const int e) {
        const int snap = e / r, q = e % r;
        T gc = 0, gr = 0;
        for (int b = snap * samples_per_snapshot; b < (snap + 1) * samples_per_snapshot; ++b) {
          gc += Hbar0(b, 0, 3 + q);
          if (channels.velocity >= 0) gr += Hbar0(b, channels.velocity, 3 + q);
        }
        code_grad(snap, q) = gc;
        rate_grad(snap, q) = gr;
      });
}

// The auto-decoder's codes: code s at params(code_offset + s * r + q); its rate xhatdot_s =
// (code[rate_to(s)] - code[rate_from(s)]) * rate_inv_dt(s), a finite difference of consecutive snapshots' codes.
template <class T, class MemorySpace>
struct CodeTable {
  int code_offset = 0;
  int latent_dim = 0;
  Kokkos::View<const int*, MemorySpace> rate_from, rate_to;
  Kokkos::View<const T*, MemorySpace> rate_inv_dt;
};

// The codes and rates of a minibatch's snapshots: codes, rates (batch snapshots, r).
template <class ExecutionSpace, class T, class MemorySpace>
void gather_codes(const ExecutionSpace& space, const CodeTable<T, MemorySpace> table,
                  const Kokkos::View<const T*, MemorySpace>& params,
                  const Kokkos::View<const int*, MemorySpace>& batch_snapshot,
                  const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& codes,
                  const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& rates) {
  const int r = table.latent_dim;
  Kokkos::parallel_for(
      "mpmrom::nn::train::gather_codes",
      Kokkos::RangePolicy<ExecutionSpace>(space, 0, int(batch_snapshot.extent(0)) * r), KOKKOS_LAMBDA(const int e) {
        const int snap = e / r, q = e % r;
        const int s = batch_snapshot(snap);
        const int o = table.code_offset;
        codes(snap, q) = params(o + s * r + q);
        rates(snap, q) =
            (params(o + table.rate_to(s) * r + q) - params(o + table.rate_from(s) * r + q)) * table.rate_inv_dt(s);
      });
}

// Adds the minibatch's code and rate adjoints to the codes' entries of grad (which the caller zeroed): one thread
// per latent component walks the batch in order, because batch snapshots share codes through the rate stencil.
template <class ExecutionSpace, class T, class MemorySpace>
void scatter_code_gradients(const ExecutionSpace& space, const CodeTable<T, MemorySpace> table,
                            const Kokkos::View<const int*, MemorySpace>& batch_snapshot,
                            const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& code_grad,
                            const Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>& rate_grad,
                            const Kokkos::View<T*, MemorySpace>& grad) {
  const int r = table.latent_dim;
  const int num_snapshots = int(batch_snapshot.extent(0));
  Kokkos::parallel_for(
      "mpmrom::nn::train::scatter_codes", Kokkos::RangePolicy<ExecutionSpace>(space, 0, r), KOKKOS_LAMBDA(const int q) {
        const int o = table.code_offset;
        for (int snap = 0; snap < num_snapshots; ++snap) {
          const int s = batch_snapshot(snap);
          const T gr = rate_grad(snap, q) * table.rate_inv_dt(s);
          grad(o + s * r + q) += code_grad(snap, q);
          grad(o + table.rate_to(s) * r + q) += gr;
          grad(o + table.rate_from(s) * r + q) -= gr;
        }
      });
}

// Activations and adjoints of one minibatch, sized once and reused every step.
template <class T, class MemorySpace>
struct TrainingBuffers {
  std::vector<Activations<T, MemorySpace>> H;                   // input of layer l, (samples, channels, dims[l])
  std::vector<Activations<T, MemorySpace>> A;                   // pre-activations of layer l (A.back() is the output y)
  Activations<T, MemorySpace> bar[2];                           // adjoints, ping-pong, (samples, channels, widest)
  Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace> partial;  // (chunks, network parameters)
  Kokkos::View<T*, MemorySpace> transposed_weights;             // W_l^T of every layer (row-wise kernels only)
  Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace> codes, rates, code_grad, rate_grad;  // (batch snapshots, r)

  template <class ExecutionSpace>
  TrainingBuffers(ExecutionSpace, const MlpLayout& layout, const Channels channels, const int num_samples,
                  const int num_batch_snapshots) {
    const int C = channels.count;
    for (int l = 0; l < layout.num_layers; ++l) {
      H.emplace_back("mpmrom::nn::H", num_samples, C, layout.dims[l]);
      A.emplace_back("mpmrom::nn::A", num_samples, C, layout.dims[l + 1]);
    }
    for (auto& b : bar) b = Activations<T, MemorySpace>("mpmrom::nn::adjoint", num_samples, C, layout.widest);
    const int chunk = weight_gradient_chunk<ExecutionSpace>();
    partial = decltype(partial)("mpmrom::nn::partial", (num_samples + chunk - 1) / chunk, layout.num_params);
    if (row_wise_kernels<ExecutionSpace>())
      transposed_weights = decltype(transposed_weights)("mpmrom::nn::weights_t", layout.num_params);
    const int r = layout.latent_dim;
    codes = decltype(codes)("mpmrom::nn::batch_codes", num_batch_snapshots, r);
    rates = decltype(rates)("mpmrom::nn::batch_rates", num_batch_snapshots, r);
    code_grad = decltype(code_grad)("mpmrom::nn::code_grad", num_batch_snapshots, r);
    rate_grad = decltype(rate_grad)("mpmrom::nn::rate_grad", num_batch_snapshots, r);
  }
};

// Forward pass of a minibatch (codes and rates gathered from params) and its loss terms; with gradient, also the
// backward pass: grad (same size as params) receives dloss/dparams for every weight and every code.
template <class ExecutionSpace, class T, class MemorySpace>
LossTerms<T> minibatch_loss(const ExecutionSpace& space, const Mlp<T, MemorySpace>& mlp,
                            const CodeTable<T, MemorySpace>& table, const Channels channels,
                            const LossWeights<T>& weights, const BatchSamples<T, MemorySpace>& batch,
                            TrainingBuffers<T, MemorySpace>& buffers, const Kokkos::View<T*, MemorySpace>& grad) {
  const int L = mlp.layout.num_layers;
  const bool with_gradient = grad.extent(0) > 0;
  gather_codes(space, table, mlp.params, batch.snapshot, buffers.codes, buffers.rates);
  fill_inputs(space, mlp, channels, batch, CodesView<T, MemorySpace>(buffers.codes),
              CodesView<T, MemorySpace>(buffers.rates), buffers.H[0]);
  if (buffers.transposed_weights.extent(0) > 0) transpose_weights(space, mlp, buffers.transposed_weights);
  for (int l = 0; l < L; ++l)
    layer_forward(space, mlp, l, channels, buffers.H[l], buffers.A[l],
                  l + 1 < L ? buffers.H[l + 1] : Activations<T, MemorySpace>(),
                  Kokkos::View<const T*, MemorySpace>(buffers.transposed_weights));
  const LossTerms<T> terms = loss_and_output_adjoint(space, mlp, channels, weights, batch, buffers.A[L - 1],
                                                     with_gradient ? buffers.bar[0] : Activations<T, MemorySpace>());
  if (!with_gradient) return terms;

  int current = 0;  // bar[current]: adjoint of layer l's output, then of its pre-activations
  for (int l = L - 1; l >= 0; --l) {
    if (l + 1 < L) activation_backward(space, channels, buffers.A[l], buffers.bar[current]);
    weight_gradient_partials(space, mlp.layout, l, channels, buffers.bar[current], buffers.H[l], buffers.partial);
    layer_input_adjoint(space, mlp, l, channels, buffers.bar[current], buffers.bar[1 - current]);
    current = 1 - current;
  }
  sum_partials(space, buffers.partial, grad);
  code_adjoints(space, channels, batch.samples_per_snapshot, buffers.bar[current], buffers.code_grad,
                buffers.rate_grad);
  Kokkos::deep_copy(space, Kokkos::subview(grad, Kokkos::make_pair(table.code_offset, int(grad.extent(0)))), T(0));
  scatter_code_gradients(space, table, batch.snapshot, buffers.code_grad, buffers.rate_grad, grad);
  return terms;
}

}  // namespace mpmrom::nn
