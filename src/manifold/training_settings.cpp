// TrainingSettings (manifold/trainer.hpp): its JSON form, as a model file records it, and its checks.
#include "manifold/trainer.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mpmrom {

// The settings a model file records, each under its member's name; checkpoint_seconds is not one of them (it does
// not change what training computes).
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(TrainingSettings, latent_dim, width, depth, lambda_gradient, lambda_velocity,
                                   lambda_affine, epochs, batch_snapshots, points_per_snapshot, max_points,
                                   learning_rate, final_learning_rate, validation_fraction, validate_every, seed)

nlohmann::json TrainingSettings::to_json() const { return nlohmann::json(*this); }

TrainingSettings TrainingSettings::from_json(const nlohmann::json& j) { return j.get<TrainingSettings>(); }

void TrainingSettings::validate() const {
  nn::MlpLayout::make(latent_dim, width, depth);  // throws on a bad architecture
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
  };
  require(std::isfinite(lambda_gradient) && lambda_gradient >= 0, "lambda-grad must be >= 0");
  require(std::isfinite(lambda_velocity) && lambda_velocity >= 0, "lambda-vel must be >= 0");
  require(std::isfinite(lambda_affine) && lambda_affine >= 0, "lambda-affine must be >= 0");
  require(epochs >= 1, "epochs must be >= 1");
  require(batch_snapshots >= 1, "batch-snapshots must be >= 1");
  require(points_per_snapshot >= 1, "points-per-snapshot must be >= 1");
  require(max_points >= 0, "max-points must be >= 0");
  require(learning_rate > 0 && final_learning_rate > 0 && std::isfinite(learning_rate) &&
              std::isfinite(final_learning_rate),
          "learning rates must be positive");
  require(validation_fraction >= 0 && validation_fraction < 1, "validation fraction must be in [0, 1)");
  require(validate_every >= 0, "validate-every must be >= 0");
}

}  // namespace mpmrom
