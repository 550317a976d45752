#include "scene/sampling.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "core/checked_integer.hpp"

namespace mpmrom {

double body_volume(const BodySpec& b) {
  switch (b.shape) {
    case ShapeKind::Box: return 8 * b.half_extents[0] * b.half_extents[1] * b.half_extents[2];
    case ShapeKind::Cylinder: return M_PI * b.radius * b.radius * b.height;
    case ShapeKind::Sphere: return 4.0 / 3.0 * M_PI * b.radius * b.radius * b.radius;
  }
  return 0;
}

bool body_contains(const BodySpec& b, const Vec3d& p) {
  const double dx = p[0] - b.center[0], dy = p[1] - b.center[1], dz = p[2] - b.center[2];
  switch (b.shape) {
    case ShapeKind::Box:
      return std::fabs(dx) <= b.half_extents[0] && std::fabs(dy) <= b.half_extents[1] &&
             std::fabs(dz) <= b.half_extents[2];
    case ShapeKind::Cylinder: return dx * dx + dy * dy <= b.radius * b.radius && std::fabs(dz) <= b.height / 2;
    case ShapeKind::Sphere: return dx * dx + dy * dy + dz * dz <= b.radius * b.radius;
  }
  return false;
}

namespace {

// Visits the lattice points inside the body; returns how many there are.
template <class Visit>
long for_each_lattice_point(const BodySpec& b, double s, Visit&& visit) {
  const auto name = [&] { return "body '" + b.name + "': its half-width in lattice spacings"; };
  int n[3];
  for (int d = 0; d < 3; ++d) n[d] = impl::checked_integer<int>(std::ceil(b.half_extents[d] / s) + 1, name, 1);
  long count = 0;
  for (int i = -n[0]; i < n[0]; ++i)
    for (int j = -n[1]; j < n[1]; ++j)
      for (int k = -n[2]; k < n[2]; ++k) {
        const Vec3d p{b.center[0] + (i + 0.5) * s, b.center[1] + (j + 0.5) * s, b.center[2] + (k + 0.5) * s};
        if (body_contains(b, p)) {
          visit(p);
          ++count;
        }
      }
  return count;
}

long lattice_count(const BodySpec& b, double s) {
  return for_each_lattice_point(b, s, [](const Vec3d&) {});
}

}  // namespace

std::vector<Vec3d> lattice_points(const BodySpec& b, double spacing) {
  if (!(spacing > 0)) throw std::runtime_error("lattice spacing must be positive");
  const double estimate = body_volume(b) / (spacing * spacing * spacing);
  if (estimate > 2e9) throw std::runtime_error("lattice spacing gives more than 2e9 points");
  std::vector<Vec3d> points;
  points.reserve(static_cast<std::size_t>(estimate * 1.1) + 8);
  for_each_lattice_point(b, spacing, [&](const Vec3d& p) { points.push_back(p); });
  return points;
}

double lattice_spacing_for_count(const BodySpec& b, long count) {
  // The count falls (not strictly) as the spacing grows. Bisect for the crossing, then scan the neighbourhood for a
  // spacing that gives the count exactly, taking the middle of the exact range so rounding cannot tip it.
  const double guess = std::cbrt(body_volume(b) / count);
  double lo = 0.5 * guess, hi = 2.0 * guess;  // count(lo) >= count >= count(hi)
  for (int it = 0; it < 60 && hi - lo > 1e-12 * guess; ++it) {
    const double mid = 0.5 * (lo + hi);
    (lattice_count(b, mid) >= count ? lo : hi) = mid;
  }
  const double step = 2e-5 * guess;
  const int max_steps = count > 200000 ? 50 : 2000;
  for (int k = 0; k <= max_steps; ++k) {
    for (double s0 : {lo - k * step, lo + k * step}) {
      if (lattice_count(b, s0) != count) continue;
      double first = s0, last = s0;
      while (lattice_count(b, first - step) == count) first -= step;
      while (lattice_count(b, last + step) == count) last += step;
      return 0.5 * (first + last);
    }
  }
  throw std::runtime_error("body '" + b.name + "': no lattice spacing gives exactly " + std::to_string(count) +
                           " points (nearest: " + std::to_string(lattice_count(b, lo)) + "); give a spacing instead");
}

std::vector<Vec3d> poisson_disk_points(const BodySpec& b, double radius, unsigned seed) {
  // Bridson's algorithm in the bounding box, on a background grid of cell radius / sqrt(3); points outside the shape
  // are dropped at the end so the boundary is sampled like the interior.
  const double cell = radius / std::sqrt(3.0);
  Vec3d lo;
  double cells = 1, cells_per_axis[3];  // counted in doubles first: converted to int only once known to fit
  for (int d = 0; d < 3; ++d) {
    lo[d] = b.center[d] - b.half_extents[d];
    cells_per_axis[d] = std::ceil(2 * b.half_extents[d] / cell) + 1;
    cells *= cells_per_axis[d];
  }
  if (cells > 4e8) throw std::runtime_error("Poisson-disk radius too small for the body (over 4e8 cells)");
  const int n[3] = {int(cells_per_axis[0]), int(cells_per_axis[1]), int(cells_per_axis[2])};
  std::vector<int> grid(static_cast<std::size_t>(cells), -1);
  auto cell_of = [&](const Vec3d& p, int c[3]) {
    for (int d = 0; d < 3; ++d) c[d] = std::min(n[d] - 1, std::max(0, int((p[d] - lo[d]) / cell)));
  };
  auto index = [&](const int c[3]) { return (std::size_t(c[0]) * n[1] + c[1]) * n[2] + c[2]; };
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  std::vector<Vec3d> points, active;
  auto far_enough = [&](const Vec3d& p) {
    int c[3];
    cell_of(p, c);
    for (int i = std::max(0, c[0] - 2); i <= std::min(n[0] - 1, c[0] + 2); ++i)
      for (int j = std::max(0, c[1] - 2); j <= std::min(n[1] - 1, c[1] + 2); ++j)
        for (int k = std::max(0, c[2] - 2); k <= std::min(n[2] - 1, c[2] + 2); ++k) {
          const int q[3] = {i, j, k};
          const int other = grid[index(q)];
          if (other < 0) continue;
          double d2 = 0;
          for (int d = 0; d < 3; ++d) d2 += (p[d] - points[other][d]) * (p[d] - points[other][d]);
          if (d2 < radius * radius) return false;
        }
    return true;
  };
  auto add = [&](const Vec3d& p) {
    int c[3];
    cell_of(p, c);
    grid[index(c)] = static_cast<int>(points.size());
    points.push_back(p);
    active.push_back(p);
  };
  add(b.center);
  const int attempts = 30;
  while (!active.empty()) {
    const std::size_t pick = static_cast<std::size_t>(uniform(rng) * active.size()) % active.size();
    const Vec3d base = active[pick];
    bool placed = false;
    for (int a = 0; a < attempts; ++a) {
      // Uniform in the spherical shell [r, 2r] around the active point.
      Vec3d dir;
      double len2;
      do {
        for (int d = 0; d < 3; ++d) dir[d] = 2 * uniform(rng) - 1;
        len2 = dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2];
      } while (len2 > 1 || len2 < 1e-12);
      const double rr = radius * std::cbrt(1 + 7 * uniform(rng)) / std::sqrt(len2);
      Vec3d p;
      bool inside = true;
      for (int d = 0; d < 3; ++d) {
        p[d] = base[d] + rr * dir[d];
        inside = inside && p[d] >= lo[d] && p[d] <= lo[d] + 2 * b.half_extents[d];
      }
      if (inside && far_enough(p)) {
        add(p);
        placed = true;
        break;
      }
    }
    if (!placed) {
      active[pick] = active.back();
      active.pop_back();
    }
  }
  std::vector<Vec3d> kept;
  for (const auto& p : points)
    if (body_contains(b, p)) kept.push_back(p);
  return kept;
}

ParticleSamples sample_scene(const Scene& scene) {
  ParticleSamples samples;
  for (std::size_t k = 0; k < scene.bodies.size(); ++k) {
    const BodySpec& b = scene.bodies[k];
    std::vector<Vec3d> points;
    if (b.sampling == SamplingKind::Explicit) {
      for (const auto& offset : b.points) {
        const Vec3d p{b.center[0] + offset[0], b.center[1] + offset[1], b.center[2] + offset[2]};
        if (!body_contains(b, p)) throw std::runtime_error("body '" + b.name + "': an explicit point lies outside it");
        points.push_back(p);
      }
    } else if (b.sampling == SamplingKind::Lattice) {
      points = lattice_points(b, b.count > 0 ? lattice_spacing_for_count(b, b.count) : b.spacing);
    } else {
      if (b.count > 0) throw std::runtime_error("body '" + b.name + "': Poisson-disk sampling takes a spacing");
      points = poisson_disk_points(b, b.spacing, b.seed);
    }
    if (points.empty()) throw std::runtime_error("body '" + b.name + "' has no material points (spacing too large)");
    const double volume = body_volume(b) / points.size();
    for (const auto& p : points) {
      const Vec3d r{p[0] - b.center[0], p[1] - b.center[1], p[2] - b.center[2]};
      const Vec3d& w = b.angular_velocity;
      const Vec3d spin{w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]};
      for (int d = 0; d < 3; ++d) {
        samples.X.push_back(p[d]);
        samples.velocity.push_back(b.velocity[d] + spin[d]);
      }
      samples.volume.push_back(volume);
      samples.mass.push_back(scene.material.density * volume);
      samples.body.push_back(static_cast<int>(k));
    }
  }
  return samples;
}

}  // namespace mpmrom
