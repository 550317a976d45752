#include "rom/scene_points.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene/sampling.hpp"

namespace mpmrom {
namespace {

struct BodyExtent {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  double mass = 0, spacing = 0;  // spacing: the cube root of the mean volume a point carries
};

BodyExtent extent(const std::vector<double>& X, const std::vector<double>& mass, const std::vector<double>& volume) {
  BodyExtent e;
  for (std::size_t i = 0; i < X.size(); ++i) {
    e.lo[i % 3] = std::min(e.lo[i % 3], X[i]);
    e.hi[i % 3] = std::max(e.hi[i % 3], X[i]);
  }
  e.mass = std::accumulate(mass.begin(), mass.end(), 0.0);
  const double total_volume = std::accumulate(volume.begin(), volume.end(), 0.0);
  e.spacing = volume.empty() ? 0 : std::cbrt(total_volume / double(volume.size()));
  return e;
}

std::string describe(const BodyExtent& e) {
  char text[200];
  std::snprintf(text, sizeof text, "mass %.6g kg, box [%.4g, %.4g] x [%.4g, %.4g] x [%.4g, %.4g] m", e.mass, e.lo[0],
                e.hi[0], e.lo[1], e.hi[1], e.lo[2], e.hi[2]);
  return text;
}

}  // namespace

Model model_at_scene_points(const Model& model, const Scene& scene) {
  const ParticleSamples points = sample_scene(scene);
  const BodyExtent own = extent(model.X, model.mass, model.volume),
                   other = extent(points.X, points.mass, points.volume);
  // A lattice's outermost points lie within half a spacing of the surface, so two lattices' boxes differ by less
  // than a spacing; twice the coarser one's leaves room for rounding at the surface.
  const double slack = 2 * std::max(own.spacing, other.spacing);
  bool same = std::fabs(own.mass - other.mass) <= 1e-6 * own.mass;
  for (int d = 0; d < 3; ++d)
    same = same && std::fabs(own.lo[d] - other.lo[d]) <= slack && std::fabs(own.hi[d] - other.hi[d]) <= slack;
  if (!same)
    throw std::runtime_error("scene '" + scene.name + "' (" + describe(other) + ") is not the body the model was " +
                             "trained on (scene '" + model.scene_name + "', " + describe(own) + ")");
  Model moved = model;
  moved.X = points.X;
  moved.mass = points.mass;
  moved.volume = points.volume;
  moved.sample_ranking.clear();
  moved.projection_samples.clear();
  moved.projection_weights.clear();
  moved.scene_name = scene.name;
  moved.scene_text = scene.source_text;
  return moved;
}

}  // namespace mpmrom
