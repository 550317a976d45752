// The shape of the deformation map's network (docs/training.md): layer sizes, where each layer's parameters sit in
// the flat parameter array, and the input and output standardisation. Used by model files and the network kernels.
#pragma once

#include <Kokkos_Macros.hpp>

#include <stdexcept>
#include <string>

namespace mpmrom::nn {

inline constexpr int max_layers = 8;   // affine layers, hidden and output together
inline constexpr int max_width = 128;  // widest layer (and 3 + r) that the one-thread kernels hold in registers
inline constexpr int output_dim = 3;

// The shape of the network and where each layer's parameters sit in the flat parameter array.
struct MlpLayout {
  int num_layers = 0;
  int latent_dim = 0;
  int dims[max_layers + 1] = {};       // layer l maps dims[l] -> dims[l + 1]; dims[0] = 3 + r, dims[num_layers] = 3
  int weight_offset[max_layers] = {};  // W_l(i, j) = params[weight_offset[l] + i * dims[l] + j]
  int bias_offset[max_layers] = {};    // b_l(i) = params[bias_offset[l] + i]
  int num_params = 0;
  int widest = 0;  // max over dims

  // depth affine layers: depth - 1 hidden layers of `width` ELU units and a linear output layer.
  static MlpLayout make(int latent_dim, int width, int depth) {
    if (latent_dim < 1 || 3 + latent_dim > max_width)
      throw std::invalid_argument("latent dimension must be in [1, " + std::to_string(max_width - 3) + "], got " +
                                  std::to_string(latent_dim));
    if (width < 1 || width > max_width)
      throw std::invalid_argument("width must be in [1, " + std::to_string(max_width) + "], got " +
                                  std::to_string(width));
    if (depth < 2 || depth > max_layers)
      throw std::invalid_argument("depth (affine layers) must be in [2, " + std::to_string(max_layers) + "], got " +
                                  std::to_string(depth));
    MlpLayout layout;
    layout.num_layers = depth;
    layout.latent_dim = latent_dim;
    layout.dims[0] = 3 + latent_dim;
    for (int l = 1; l < depth; ++l) layout.dims[l] = width;
    layout.dims[depth] = output_dim;
    int offset = 0;
    for (int l = 0; l < depth; ++l) {
      layout.weight_offset[l] = offset;
      offset += layout.dims[l + 1] * layout.dims[l];
      layout.bias_offset[l] = offset;
      offset += layout.dims[l + 1];
    }
    layout.num_params = offset;
    for (int l = 0; l <= depth; ++l) layout.widest = layout.dims[l] > layout.widest ? layout.dims[l] : layout.widest;
    return layout;
  }

  KOKKOS_INLINE_FUNCTION int width() const { return dims[1]; }
  // Multiply-adds of one forward evaluation (the affine layers; activations not counted).
  KOKKOS_INLINE_FUNCTION long forward_macs() const {
    long macs = 0;
    for (int l = 0; l < num_layers; ++l) macs += long(dims[l]) * dims[l + 1];
    return macs;
  }
};

// Input and output standardisation, stored in the model: z_X = (X - input_mean) / input_scale and
// g = X + output_mean + output_scale * y.
template <class T>
struct Standardization {
  T input_mean[3] = {0, 0, 0};
  T input_scale[3] = {1, 1, 1};
  T output_mean[3] = {0, 0, 0};
  T output_scale[3] = {1, 1, 1};
};

}  // namespace mpmrom::nn
