// model_at_scene_points (rom/scene_points.hpp): a model's network at another lattice of the body it was trained on,
// and a one-line refusal for another body.
#include <gtest/gtest.h>

#include <stdexcept>

#include "rom/scene_points.hpp"
#include "scene/sampling.hpp"
#include "fixtures.hpp"

namespace mpmrom::test {
namespace {

// A model whose reference points are the scene's, with a network, codes and stored sample sets to carry over.
Model model_on(const Scene& scene) {
  Model model;
  model.latent_dim = 2;
  model.width = 4;
  model.depth = 3;
  model.weights.assign(std::size_t(model.layout().num_params), 0.25);
  model.codes = {0.1, 0.2, 0.3, 0.4};
  const ParticleSamples points = sample_scene(scene);
  model.X = points.X;
  model.mass = points.mass;
  model.volume = points.volume;
  model.sample_ranking = {0, 1, 2};
  model.projection_samples = {1};
  model.projection_weights = {2.0};
  model.scene_name = scene.name;
  return model;
}

TEST(ModelAtScenePoints, TakesTheScenesLatticeOfTheSameBody) {
  const Scene coarse = fixture_scene("affine_motion.toml");
  const Model model = model_on(coarse);
  for (const double factor : {2.0, 0.5}) {
    const Scene other = refine_scene(coarse, factor);
    const ParticleSamples points = sample_scene(other);
    ASSERT_NE(points.size(), model.num_points()) << factor;
    const Model moved = model_at_scene_points(model, other);
    EXPECT_EQ(moved.X, points.X);
    EXPECT_EQ(moved.mass, points.mass);
    EXPECT_EQ(moved.volume, points.volume);
    EXPECT_EQ(moved.weights, model.weights);  // the same manifold
    EXPECT_EQ(moved.codes, model.codes);
    // the stored sets name points of the old lattice
    EXPECT_TRUE(moved.sample_ranking.empty());
    EXPECT_TRUE(moved.projection_samples.empty());
    EXPECT_TRUE(moved.projection_weights.empty());
  }
}

TEST(ModelAtScenePoints, RefusesAnotherBody) {
  const Scene scene = fixture_scene("affine_motion.toml");
  const Model model = model_on(scene);
  Scene shifted = scene;  // the same mass three lattice spacings (0.075 m) away: beyond the two allowed
  shifted.bodies[0].center[2] += 3 * scene.bodies[0].spacing;
  EXPECT_THROW(model_at_scene_points(model, shifted), std::runtime_error);
  Scene denser = scene;  // the same box, 1 % heavier
  denser.material.density *= 1.01;
  EXPECT_THROW(model_at_scene_points(model, denser), std::runtime_error);
  EXPECT_NO_THROW(model_at_scene_points(model, scene));
}

}  // namespace
}  // namespace mpmrom::test
