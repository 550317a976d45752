// The reduced model's evaluations of the trained network on the host's behalf (rom/decode.cpp): kept in one translation
// unit, which instantiates the network's kernels for the ROM stage.
#pragma once

#include <cstddef>
#include <vector>

#include "mpmrom/model.hpp"
#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// Positions of every reference point at the given training codes of the model (empty: every code): (codes, points, 3).
std::vector<double> training_positions(const Model& model, const std::vector<int>& codes = {});

// dg/dxhat of the model's network at points X (n, 3) for each of codes (count, r): (count, n, 3, r).
std::vector<double> decoder_jacobians(const Model& model, const std::vector<double>& X,
                                      const std::vector<double>& codes);

// decode() a few codes a pass, each pass's dg/dxhat at most values_per_pass values (at least one code a pass).
DecodedFields decode_in_passes(const Model& model, const std::vector<double>& X, const std::vector<double>& codes,
                               const std::vector<double>& rates, std::size_t values_per_pass);

}  // namespace mpmrom::impl
