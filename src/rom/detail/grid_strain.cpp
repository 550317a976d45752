#include "rom/detail/grid_strain.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include "mpm/bspline.hpp"

namespace mpmrom::impl {
namespace {

// The points whose stencil starts at each base node (key: node index), to gather a node's contributors.
std::unordered_map<long, std::vector<int>> points_by_base(const GridGeometry<real_t>& grid,
                                                          const std::vector<double>& X) {
  std::unordered_map<long, std::vector<int>> by_base;
  for (std::size_t p = 0; p < X.size() / 3; ++p) {
    const Vec3<real_t> x{{real_t(X[3 * p]), real_t(X[3 * p + 1]), real_t(X[3 * p + 2])}};
    const auto stencil = quadratic_stencil(x, grid.origin, grid.inv_dx);
    if (!grid.stencil_inside(stencil.base)) continue;
    by_base[grid.index(stencil.base[0], stencil.base[1], stencil.base[2])].push_back(int(p));
  }
  return by_base;
}

// Per axis, whether the boundary holds node idx at rest (both signs of a trial velocity give 0).
Vec3<real_t> free_axes(const GridGeometry<real_t>& grid, const GridBoundary& boundary, const int idx[3]) {
  const Vec3<real_t> up = constrained_node_velocity(Vec3<real_t>{{1, 1, 1}}, idx, grid, boundary);
  const Vec3<real_t> down = constrained_node_velocity(Vec3<real_t>{{-1, -1, -1}}, idx, grid, boundary);
  Vec3<real_t> free;
  for (int d = 0; d < 3; ++d) free[d] = up[d] == 0 && down[d] == 0 ? 0 : 1;
  return free;
}

void require_resting_boundary(const rom::RolloutLoads& loads, double end_time) {
  const GridBoundary& b = loads.boundary;
  for (int r = 0; r < b.num_dirichlet; ++r) {
    const bool rest = b.dirichlet_velocity[3 * r] == 0 && b.dirichlet_velocity[3 * r + 1] == 0 &&
                      b.dirichlet_velocity[3 * r + 2] == 0;
    const bool always = loads.dirichlet_window[2 * r] <= 0 && loads.dirichlet_window[2 * r + 1] >= end_time;
    if (!rest || !always)
      throw std::invalid_argument(
          "--galerkin-strain grid needs every [[dirichlet]] region at rest over the whole run (a moving or "
          "switching region has no rest configuration)");
  }
}

// The node's row of GridStrainNodes::nodes: where it takes its velocity from, and its free axes.
void node_row(const GridGeometry<real_t>& grid, const GridBoundary& boundary,
              const std::unordered_map<long, std::vector<int>>& by_base, const std::vector<double>& X,
              const std::vector<double>& mass, const int idx[3], bool apic, bool node_average, double* row) {
  double weight = 0, centroid[3] = {0, 0, 0};
  // A point reaches this node from the stencils based at idx - (0..2) on each axis.
  for (int o = 0; o < 27; ++o) {
    const int base[3] = {idx[0] - o / 9, idx[1] - (o / 3) % 3, idx[2] - o % 3};
    if (!grid.stencil_inside(base)) continue;
    const auto found = by_base.find(grid.index(base[0], base[1], base[2]));
    if (found == by_base.end()) continue;
    for (const int p : found->second) {
      const Vec3<real_t> x{{real_t(X[3 * p]), real_t(X[3 * p + 1]), real_t(X[3 * p + 2])}};
      const auto at = quadratic_stencil(x, grid.origin, grid.inv_dx);
      const double w = double(at.weight(idx[0] - at.base[0], idx[1] - at.base[1], idx[2] - at.base[2])) * mass[p];
      weight += w;
      for (int d = 0; d < 3; ++d) centroid[d] += w * X[3 * p + d];
    }
  }
  if (!(weight > 0))  // the sample itself is among the node's contributors
    throw std::logic_error("grid_strain_nodes: a sample's node receives no mass");
  const Vec3<real_t> free = free_axes(grid, boundary, idx);
  for (int d = 0; d < 3; ++d) {
    row[d] = apic ? double(grid.position(idx[0], idx[1], idx[2])[d]) : centroid[d] / weight;
    row[3 + d] = double(free[d]);
    row[6 + d] = node_average ? centroid[d] / weight : row[d];
  }
}

}  // namespace

GridStrainNodes grid_strain_nodes(const GridGeometry<real_t>& grid, const rom::RolloutLoads& loads, double end_time,
                                  const std::vector<double>& X, const std::vector<double>& mass,
                                  const std::vector<double>& sample_X, bool apic, bool node_average) {
  require_resting_boundary(loads, end_time);
  const auto by_base = points_by_base(grid, X);
  const std::size_t S = sample_X.size() / 3;
  GridStrainNodes result;
  result.stencils.resize(S * 27);
  std::unordered_map<long, int> slot;  // grid node index -> row
  for (std::size_t s = 0; s < S; ++s) {
    const Vec3<real_t> xs{{real_t(sample_X[3 * s]), real_t(sample_X[3 * s + 1]), real_t(sample_X[3 * s + 2])}};
    const auto stencil = quadratic_stencil(xs, grid.origin, grid.inv_dx);
    if (!grid.stencil_inside(stencil.base))
      throw std::invalid_argument("--galerkin-strain grid: a sample's stencil leaves the grid");
    for (int n = 0; n < 27; ++n) {
      const int idx[3] = {stencil.base[0] + n / 9, stencil.base[1] + (n / 3) % 3, stencil.base[2] + n % 3};
      const auto [at, added] = slot.try_emplace(grid.index(idx[0], idx[1], idx[2]), int(slot.size()));
      if (added) {
        result.nodes.resize(result.nodes.size() + grid_strain_node_values);
        node_row(grid, loads.boundary, by_base, X, mass, idx, apic, node_average,
                 &result.nodes[result.nodes.size() - grid_strain_node_values]);
      }
      result.stencils[s * 27 + std::size_t(n)] = at->second;
    }
  }
  return result;
}

GridStrainViews upload_grid_strain(const GridStrainNodes& found, int rollouts, int latent_dim) {
  const std::size_t num_nodes = found.nodes.size() / grid_strain_node_values, S = found.stencils.size() / 27;
  GridStrainViews views;
  views.nodes = upload<DeviceMatrix>("mpmrom::rom::strain_nodes", found.nodes, num_nodes, grid_strain_node_values);
  views.stencils = Kokkos::View<int**, Kokkos::LayoutRight, DeviceMemory>("mpmrom::rom::strain_stencils", S, 27);
  auto host = Kokkos::create_mirror_view(views.stencils);
  std::copy(found.stencils.begin(), found.stencils.end(), host.data());
  Kokkos::deep_copy(views.stencils, host);
  views.u = DeviceCube("mpmrom::rom::strain_u", rollouts, num_nodes, 3);
  views.dg = DeviceQuad("mpmrom::rom::strain_dg", rollouts, num_nodes, 3, latent_dim);
  return views;
}

}  // namespace mpmrom::impl
