// The grid nodes of the Galerkin step's grid strain (GalerkinStrain::Grid, docs/rom.md "Galerkin step"): what each
// sample's quadratic B-spline stencil needs, precomputed in the reference configuration. Private to the rom stage.
#pragma once

#include <vector>

#include "mpm/grid.hpp"
#include "rom/kernels/loads.hpp"

namespace mpmrom::impl {

// Values per stencil node in grid_strain_stencils' rows.
inline constexpr int grid_strain_node_values = 6;

// For each sample (row-major sample_X (S, 3)), the 27 nodes of its stencil in the reference configuration
// (a, b, c order of QuadraticStencil): the mass-weighted centroid, with the node's B-spline weights, of the
// reference points (X, mass: row-major (n, 3) and (n)) whose momentum the node receives in MPM's transfer, and per
// axis 1 where the node moves freely, 0 where the boundary holds it at rest. Row-major (S, 27, 6). Throws
// std::invalid_argument when a Dirichlet region moves or is not active over [0, end_time], which a strain measured
// from the rest configuration cannot follow.
std::vector<double> grid_strain_stencils(const GridGeometry<real_t>& grid, const rom::RolloutLoads& loads,
                                         double end_time, const std::vector<double>& X, const std::vector<double>& mass,
                                         const std::vector<double>& sample_X);

}  // namespace mpmrom::impl
