// The deformation map's kinematics (mlp_kinematics.hpp) evaluated by a team: the vector lanes of one team thread
// share a point; in the forward pass lane i computes neurons i and i + n/2 of an n-neuron layer (then i + V and so
// on), in the reverse sweeps the adjoint of input i (then i + V). The point's activations (the eight channels
// of a neuron side by side, read together), the ELU slopes and the adjoints sit in team scratch; the weights are
// read transposed with an odd row stride, so that lanes read consecutive weights in the forward pass and weights one
// stride apart in the reverse sweeps, both without shared-memory bank conflicts, and may be staged in scratch once
// per team. One thread per point (SerialMlpKinematics) leaves a GPU with a few hundred threads on small batches and
// every activation in local memory; here a point's work is spread over its lanes.
#pragma once

#include <vector>

#include "manifold/nn/mlp_kinematics.hpp"

namespace mpmrom::nn {

// Where each layer sits in the transposed parameter array: Wt_l(j, i) = W_l(i, j) at weight_offset[l] + j * stride[l]
// + i, b_l(i) at bias_offset[l] + i.
struct TeamMlpLayout {
  int weight_offset[max_layers] = {};
  int stride[max_layers] = {};  // dims[l + 1] rounded up to an odd number
  int bias_offset[max_layers] = {};
  int size = 0;  // values in all

  static TeamMlpLayout make(const MlpLayout& layout) {
    TeamMlpLayout arranged;
    int offset = 0;
    for (int l = 0; l < layout.num_layers; ++l) {
      arranged.stride[l] = layout.dims[l + 1] | 1;
      arranged.weight_offset[l] = offset;
      offset += layout.dims[l] * arranged.stride[l];
      arranged.bias_offset[l] = offset;
      offset += layout.dims[l + 1];
    }
    // a whole number of channel blocks, so that what follows the staged weights in scratch stays aligned
    arranged.size = (offset + kinematics_channels - 1) / kinematics_channels * kinematics_channels;
    return arranged;
  }
};

// The parameters (MlpLayout order) rearranged as TeamMlpLayout says; the padding is zero.
template <class T, class Source>
std::vector<T> arrange_for_teams(const MlpLayout& layout, const TeamMlpLayout& arranged, const Source& params) {
  std::vector<T> values(std::size_t(arranged.size), T(0));
  for (int l = 0; l < layout.num_layers; ++l) {
    for (int i = 0; i < layout.dims[l + 1]; ++i) {
      for (int j = 0; j < layout.dims[l]; ++j)
        values[std::size_t(arranged.weight_offset[l] + j * arranged.stride[l] + i)] =
            T(params[std::size_t(layout.weight_offset[l] + i * layout.dims[l] + j)]);
      values[std::size_t(arranged.bias_offset[l] + i)] = T(params[std::size_t(layout.bias_offset[l] + i)]);
    }
  }
  return values;
}

// What the team kernels need of a network: its shapes, standardisation and the rearranged parameters (in global
// memory; a kernel may stage them in scratch and pass that copy instead).
template <class T, class MemorySpace>
struct TeamMlp {
  MlpLayout layout;
  TeamMlpLayout arranged;
  Standardization<T> standardization;
  Kokkos::View<const T*, MemorySpace> values;

  // Scratch values one team thread needs: two activation buffers of channels and the hidden layers' slopes, in
  // whole channel blocks (the buffers stay aligned).
  KOKKOS_INLINE_FUNCTION int thread_scratch_values() const {
    const int w = layout.widest;
    const int slopes = (layout.num_layers - 1) * w;
    return 2 * kinematics_channels * w + (slopes + kinematics_channels - 1) / kinematics_channels * kinematics_channels;
  }
};

// Vector lanes a team thread should give one point, two neurons a lane: the power of two up to 32 that wastes the
// fewest lanes over the widest layer's pairs of neurons (ties: the larger).
inline int lanes_for_width(int widest) {
  const int pairs = (widest + 1) / 2;
  int best = 32;
  long best_work = long((pairs + 31) / 32) * 32;
  for (int lanes = 16; lanes >= 1; lanes /= 2) {
    const long work = long((pairs + lanes - 1) / lanes) * lanes;
    if (work < best_work) {
      best = lanes;
      best_work = work;
    }
  }
  return best;
}

// Kinematics (and on request dg/dxhat) of one point per team thread; with Channels = 1 only the position g and
// dg/dxhat (out's other members are left as they were), one forward channel instead of eight, the same arithmetic
// for what it computes. Parallelism contract: every thread of the team
// calls it at once with the same any_jacobian (the team synchronises between layers); each thread's vector lanes
// share its point. A thread with active false evaluates nothing but takes part in the synchronisation; dgdxhat is
// written only where it is not null (and any_jacobian is true). weights: `net.values` or a copy of them in scratch;
// scratch: net.thread_scratch_values() values of this thread, aligned to NeuronChannels<T>; out may sit in scratch (it
// is written by the lanes, so read it after a team barrier). One function of ~100 lines: the forward pass and the
// reverse sweeps hand the same scratch buffers back and forth (h, next, adjoint, spare) between the team's barriers;
// split, each half would need the other's buffer roles.
template <int Channels = kinematics_channels, class Member, class T, class MemorySpace>
KOKKOS_INLINE_FUNCTION void TeamMlpKinematics(const Member& member, const TeamMlp<T, MemorySpace>& net,
                                              const T* weights, T* scratch, bool active, const T X[3], const T* xhat,
                                              const T* xhatdot, bool any_jacobian, PointKinematics<T>& out,
                                              T* dgdxhat) {
  static_assert(Channels == 1 || Channels == kinematics_channels, "the primal channel alone, or all of them");
  constexpr int C = kinematics_channels;
  const MlpLayout& layout = net.layout;
  const TeamMlpLayout& arranged = net.arranged;
  const Standardization<T>& s = net.standardization;
  const int L = layout.num_layers, r = layout.latent_dim, w = layout.widest;
  NeuronChannels<T>* h = reinterpret_cast<NeuronChannels<T>*>(scratch);
  NeuronChannels<T>* next = h + w;
  T* slope = scratch + 2 * C * w;  // (L - 1) x w

  Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, active ? 3 + r : 0), [&](const int j) {
    NeuronChannels<T> z;
    for (int c = 0; c < C; ++c) z.c[c] = T(0);
    if (j < 3) {
      z.c[0] = (X[j] - s.input_mean[j]) / s.input_scale[j];
      z.c[1 + j] = T(1) / s.input_scale[j];
    } else {
      z.c[0] = xhat[j - 3];
      z.c[4] = xhatdot[j - 3];
    }
    h[j] = z;
  });
  member.team_barrier();
  for (int l = 0; l < L; ++l) {
    const bool hidden = l + 1 < L;
    const int n_in = layout.dims[l], stride = arranged.stride[l];
    const T* Wt = weights + arranged.weight_offset[l];
    const T* bias = weights + arranged.bias_offset[l];
    T* layer_slope = hidden ? slope + l * w : nullptr;
    const NeuronChannels<T>* in = h;
    NeuronChannels<T>* result = next;
    // Two neurons a lane, i and i + half: each activation read from scratch feeds 16 multiply-adds, not 8.
    const int n_out = layout.dims[l + 1], half = (n_out + 1) / 2;
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, active ? half : 0), [&](const int i) {
      const bool second = i + half < n_out;
      T a[C] = {bias[i]}, b[C] = {second ? bias[i + half] : T(0)};
      for (int j = 0; j < n_in; ++j) {
        const T weight = Wt[j * stride + i], other = second ? Wt[j * stride + i + half] : T(0);
        if constexpr (Channels == 1) {
          const T hj = in[j].c[0];
          a[0] += weight * hj;
          b[0] += other * hj;
        } else {
          const NeuronChannels<T> hj = in[j];
          for (int c = 0; c < C; ++c) {
            a[c] += weight * hj.c[c];
            b[c] += other * hj.c[c];
          }
        }
      }
      finish_neuron(a, hidden, result[i], hidden ? layer_slope + i : nullptr);
      if (second) finish_neuron(b, hidden, result[i + half], hidden ? layer_slope + i + half : nullptr);
    });
    member.team_barrier();
    NeuronChannels<T>* tmp = h;
    h = next;
    next = tmp;
  }
  // h: the three outputs with their tangents; next is free for the reverse sweeps
  const NeuronChannels<T>* y = h;
  Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, active ? 3 : 0), [&](const int k) {
    out.g[k] = X[k] + s.output_mean[k] + s.output_scale[k] * y[k].c[0];
    if constexpr (Channels == 1) return;
    out.v[k] = s.output_scale[k] * y[k].c[4];
    for (int j = 0; j < 3; ++j) {
      out.F[k][j] = (k == j ? T(1) : T(0)) + s.output_scale[k] * y[k].c[1 + j];
      out.Fdot[k][j] = s.output_scale[k] * y[k].c[5 + j];
    }
  });
  if (!any_jacobian) return;

  // Three reverse sweeps at once: adjoint[3 j + k] = dy_k / d(input j of the layer), slopes folded in.
  const bool wanted = active && dgdxhat != nullptr;
  T* adjoint = reinterpret_cast<T*>(next);
  T* spare = adjoint + 3 * w;
  {
    const T* Wt = weights + arranged.weight_offset[L - 1];
    const int stride = arranged.stride[L - 1];
    const T* last_slope = slope + (L - 2) * w;
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, wanted ? layout.dims[L - 1] : 0), [&](const int j) {
      for (int k = 0; k < 3; ++k) adjoint[3 * j + k] = Wt[j * stride + k] * last_slope[j];
    });
  }
  member.team_barrier();
  for (int l = L - 2; l >= 0; --l) {
    const T* Wt = weights + arranged.weight_offset[l];
    const int stride = arranged.stride[l], n_out = layout.dims[l + 1];
    const T* below = l > 0 ? slope + (l - 1) * w : nullptr;
    const T* upstream = adjoint;
    T* result = spare;
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, wanted ? layout.dims[l] : 0), [&](const int j) {
      T sum[3] = {T(0), T(0), T(0)};
      for (int i = 0; i < n_out; ++i) {
        const T weight = Wt[j * stride + i];
        for (int k = 0; k < 3; ++k) sum[k] += weight * upstream[3 * i + k];
      }
      const T factor = below != nullptr ? below[j] : T(1);
      for (int k = 0; k < 3; ++k) result[3 * j + k] = factor * sum[k];
    });
    member.team_barrier();
    T* tmp = adjoint;
    adjoint = spare;
    spare = tmp;
  }
  const T* dydz = adjoint;
  Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, wanted ? 3 * r : 0), [&](const int e) {
    const int k = e / r, q = e % r;
    dgdxhat[e] = s.output_scale[k] * dydz[3 * (3 + q) + k];
  });
}

}  // namespace mpmrom::nn
