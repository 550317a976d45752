// Material points for the scene's bodies: a lattice (to a spacing, or to an exact count) or Poisson-disk samples.
#pragma once

#include <vector>

#include "mpmrom/scene.hpp"

namespace mpmrom {

struct ParticleSamples {
  std::vector<double> X;         // (n, 3) reference positions
  std::vector<double> velocity;  // (n, 3) initial velocities
  std::vector<double> volume;    // (n) reference volume: the body's volume shared equally
  std::vector<double> mass;      // (n) density * volume
  std::vector<int> body;         // (n) index of the body each point belongs to
  std::size_t size() const { return volume.size(); }
};

// Points of one body on the lattice center + (i + 1/2) * spacing (i integer) that lie inside the shape.
std::vector<Vec3d> lattice_points(const BodySpec& body, double spacing);

// The lattice spacing that puts exactly `count` points in the body; throws when no spacing does.
double lattice_spacing_for_count(const BodySpec& body, long count);

// Poisson-disk samples (Bridson 2007) inside the body with minimum distance `radius`, from a fixed seed.
std::vector<Vec3d> poisson_disk_points(const BodySpec& body, double radius, unsigned seed);

double body_volume(const BodySpec& body);
bool body_contains(const BodySpec& body, const Vec3d& p);

ParticleSamples sample_scene(const Scene& scene);

}  // namespace mpmrom
