// Scenes derived from a scene file (mpmrom/scene.hpp): refined, overridden, and one per run of the design from a file
// parsed once (SceneRuns).
#include "mpmrom/scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "scene/detail/toml_reader.hpp"
#include "scene/sampling.hpp"

namespace mpmrom {

Scene refine_scene(const Scene& scene, double factor) {
  if (!(factor > 0) || !std::isfinite(factor))
    throw std::runtime_error("scene " + scene.name + ": refinement factor must be positive, not " +
                             std::to_string(factor));
  const auto number = [](double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.17g", value);
    return std::string(text);
  };
  if (factor == 1) return override_scene(scene, {});
  // The refined grid keeps a node where the original has one at the bodies' lower faces (a fixed base stays on a
  // node) and grows outward to cover the original domain with the 2-cell margin the bodies need.
  const double dx = scene.dx / factor;
  std::vector<std::string> overrides{"grid.dx=" + number(dx)};
  Vec3d lo = scene.domain.lo, hi = scene.domain.hi, body_lo, body_hi;
  for (int d = 0; d < 3; ++d) {
    body_lo[d] = INFINITY;
    body_hi[d] = -INFINITY;
    for (const auto& b : scene.bodies) {
      body_lo[d] = std::min(body_lo[d], b.center[d] - b.half_extents[d]);
      body_hi[d] = std::max(body_hi[d], b.center[d] + b.half_extents[d]);
    }
    const double anchor = scene.domain.lo[d] + std::round((body_lo[d] - scene.domain.lo[d]) / scene.dx) * scene.dx;
    const double below = anchor - std::min(scene.domain.lo[d], body_lo[d] - 2 * dx);
    const double above = std::max(scene.domain.hi[d], body_hi[d] + 2 * dx) - anchor;
    lo[d] = anchor - std::ceil(below / dx - 1e-9) * dx;
    hi[d] = anchor + std::ceil(above / dx - 1e-9) * dx;
    // one more cell where round-off would put a body a hair inside the margin parse() demands
    while (body_lo[d] < lo[d] + 2 * dx) lo[d] -= dx;
    while (body_hi[d] > hi[d] - 2 * dx) hi[d] += dx;
  }
  overrides.push_back("grid.lo=[" + number(lo[0]) + "," + number(lo[1]) + "," + number(lo[2]) + "]");
  overrides.push_back("grid.hi=[" + number(hi[0]) + "," + number(hi[1]) + "," + number(hi[2]) + "]");
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const BodySpec& body = scene.bodies[i];
    if (body.sampling == SamplingKind::Explicit)
      throw std::runtime_error("scene " + scene.name + ": body '" + body.name +
                               "' is given by explicit points and cannot be refined");
    const double spacing = body.count > 0 ? lattice_spacing_for_count(body, body.count) : body.spacing;
    const std::string entry = "body." + std::to_string(i) + ".";
    overrides.push_back(entry + "spacing=" + number(spacing / factor));
    overrides.push_back(entry + "count=0");  // 0: the spacing decides
  }
  return override_scene(scene, overrides);
}

Scene override_scene(const Scene& scene, const std::vector<std::string>& overrides) {
  return impl::parse_scene_text(scene.source_path, scene.source_text, overrides, &scene.parameters);
}

struct SceneRuns::Parsed {
  std::string path, text;
  toml::table root;
};

SceneRuns::SceneRuns(const std::string& path) {
  auto parsed = std::make_shared<Parsed>();
  parsed->path = path;
  parsed->text = impl::read_text(path);
  parsed->root = impl::parse_toml(path, parsed->text);
  parsed_ = std::move(parsed);
}

Scene SceneRuns::run(const std::vector<std::string>& names, const std::vector<double>& values) const {
  std::map<std::string, double> parameters;
  for (std::size_t k = 0; k < names.size(); ++k) parameters[names[k]] = values.at(k);
  return impl::build_scene(parsed_->path, parsed_->text, parsed_->root, {}, &parameters);
}

Scene scene_for_run(const std::string& path, const std::vector<std::string>& names, const std::vector<double>& values) {
  return SceneRuns(path).run(names, values);
}

}  // namespace mpmrom
