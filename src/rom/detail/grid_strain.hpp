// The grid nodes of the Galerkin step's grid strain (GalerkinStrain::Grid, docs/rom.md "Galerkin step"): what each
// sample's quadratic B-spline stencil needs, precomputed in the reference configuration. Private to the rom stage.
#pragma once

#include <vector>

#include "manifold/device_data.hpp"
#include "mpm/grid.hpp"
#include "rom/kernels/loads.hpp"

namespace mpmrom::impl {

// Values per node in GridStrainNodes::nodes.
inline constexpr int grid_strain_node_values = 9;

// The distinct nodes of the samples' stencils, each evaluated once a step however many samples share it.
struct GridStrainNodes {
  // Per node (row-major (nodes, 9)): where the node takes its velocity from, Xbar (the node's position, or with PIC
  // the mass-weighted centroid, with the node's B-spline weights, of the reference points whose momentum it receives),
  // per axis 1 where the node moves freely, 0 where the boundary holds it at rest, and where its test function
  // dg/dxhat is taken (Xbar, or with node_average that centroid).
  std::vector<double> nodes;
  std::vector<int> stencils;  // (samples, 27): each sample's stencil nodes (QuadraticStencil's a, b, c order)
};

// The nodes of the stencils of the samples at sample_X (row-major (S, 3)) in the reference configuration of the
// points X, mass (row-major (n, 3) and (n)). With APIC a node's velocity is the material's velocity field at the
// node itself (its affine part extrapolates it beyond the free surface): Xbar is then the node's position; with PIC
// it is the centroid. node_average: the test function at the centroid whatever the transfer (RomSettings::
// galerkin_node_average). Throws std::invalid_argument when a Dirichlet region moves or is not
// active over [0, end_time], which a strain measured from the rest configuration cannot follow.
GridStrainNodes grid_strain_nodes(const GridGeometry<real_t>& grid, const rom::RolloutLoads& loads, double end_time,
                                  const std::vector<double>& X, const std::vector<double>& mass,
                                  const std::vector<double>& sample_X, bool apic, bool node_average);

// The grid strain on the device: its nodes and stencils, and room for each step's node displacements and dg/dxhat
// (GridStrainNodeKinematics) of the given rollouts; all empty when there is no grid strain.
struct GridStrainViews {
  DeviceMatrix nodes;
  Kokkos::View<int**, Kokkos::LayoutRight, DeviceMemory> stencils;
  DeviceCube u;
  DeviceQuad dg;
};
GridStrainViews upload_grid_strain(const GridStrainNodes& found, int rollouts, int latent_dim);

}  // namespace mpmrom::impl
