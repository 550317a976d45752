// A deformation-map network with random weights for the network kernels' tests: weights scaled by 1/sqrt(fan-in), as
// training starts, a standardisation far from the identity, and `num_codes` random latent codes after the weights.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "mpmrom/network.hpp"

namespace mpmrom::test {

struct HostNetwork {
  nn::MlpLayout layout;
  nn::Standardization<double> standardization;
  std::vector<double> params;  // weights, then codes
};

inline HostNetwork random_network(int latent, int width, int depth, int num_codes, unsigned seed) {
  HostNetwork net;
  net.layout = nn::MlpLayout::make(latent, width, depth);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1, 1);
  for (int l = 0; l < depth; ++l) {
    const double scale = 1.5 / std::sqrt(double(net.layout.dims[l]));
    for (int i = 0; i < net.layout.dims[l + 1] * (net.layout.dims[l] + 1); ++i)
      net.params.push_back(scale * uniform(rng));
  }
  for (int i = 0; i < num_codes * latent; ++i) net.params.push_back(uniform(rng));
  for (int d = 0; d < 3; ++d) {
    net.standardization.input_mean[d] = 0.1 * uniform(rng);
    net.standardization.input_scale[d] = 0.2 + 0.05 * d;
    net.standardization.output_mean[d] = 0.01 * uniform(rng);
    net.standardization.output_scale[d] = 0.05 + 0.02 * d;
  }
  return net;
}

}  // namespace mpmrom::test
