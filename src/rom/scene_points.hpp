// A model decoded at another lattice of the body it was trained on: the same network and codes (so the same
// manifold x = g(X; xhat)) with a scene's own material points as its reference points. `mpmrom bench rom` times the
// reduced step with one network at 10^4 to 10^7 points this way.
#pragma once

#include "mpmrom/model.hpp"
#include "mpmrom/scene.hpp"

namespace mpmrom {

// The model with the scene's material points (sample_scene) as its reference points X, mass and volume; its stored
// sample sets, which name the old points, are dropped. Throws std::runtime_error with one line when the scene's
// bodies are not the model's body: another total mass (1e-6 relative), or a bounding box more than two lattice
// spacings (the coarser one's) away on some axis.
Model model_at_scene_points(const Model& model, const Scene& scene);

}  // namespace mpmrom
