#include "mpmrom/rollout_batch.hpp"

#include <stdexcept>
#include <string>

#include "rom/detail/rollout_driver.hpp"
#include "rom/kernels/projection.hpp"

namespace mpmrom {
namespace {

void require_rollout(int rollout, int size) {
  if (rollout < 0 || rollout >= size)
    throw std::out_of_range("rollout " + std::to_string(rollout) + " of " + std::to_string(size));
}

void require_points(const std::vector<double>& X, const char* what) {
  if (X.size() % 3 != 0)
    throw std::invalid_argument(std::string(what) + ": points must be (n, 3), got " + std::to_string(X.size()) +
                                " values");
}

}  // namespace

RolloutBatch::RolloutBatch(const Model& model, const std::string& scene_path, const std::vector<std::string>& names,
                           const std::vector<RolloutCase>& cases, const RomSettings& settings,
                           const HyperReduction& reduction)
    : RolloutBatch(std::make_shared<const Model>(model), scene_path, names, cases, settings, reduction) {}

RolloutBatch::RolloutBatch(std::shared_ptr<const Model> model, const std::string& scene_path,
                           const std::vector<std::string>& names, const std::vector<RolloutCase>& cases,
                           const RomSettings& settings, const HyperReduction& reduction)
    : model_(std::move(model)),
      names_(names),
      cases_(cases),
      stepper_(impl::create_stepper(*model_, scene_path, names, cases, settings, reduction)) {
  stepper_->warm_up();
}

RolloutBatch::~RolloutBatch() = default;
RolloutBatch::RolloutBatch(RolloutBatch&&) noexcept = default;
RolloutBatch& RolloutBatch::operator=(RolloutBatch&&) noexcept = default;

int RolloutBatch::size() const { return stepper_->rollouts(); }
int RolloutBatch::latent_dim() const { return stepper_->latent_dim(); }
int RolloutBatch::frame() const { return stepper_->frame(); }
int RolloutBatch::frames() const { return stepper_->frames(); }
double RolloutBatch::time() const { return stepper_->time(); }
const std::vector<double>& RolloutBatch::times() const { return stepper_->times(); }
long RolloutBatch::steps() const { return stepper_->steps(); }
bool RolloutBatch::advance() { return stepper_->advance_frame(); }

std::vector<double> RolloutBatch::latent_state() const {
  std::vector<double> xhat, xhatdot;
  stepper_->latent(xhat, xhatdot);
  return xhat;
}

std::vector<double> RolloutBatch::latent_rate() const {
  std::vector<double> xhat, xhatdot;
  stepper_->latent(xhat, xhatdot);
  return xhatdot;
}

std::vector<RolloutOutcome> RolloutBatch::outcomes() const {
  auto outcomes = stepper_->outcomes();
  const auto warnings = training_range_warnings(*model_, names_, cases_);
  for (std::size_t c = 0; c < cases_.size(); ++c) outcomes[c].warning = warnings[c];
  return outcomes;
}

bool RolloutBatch::running(int rollout) const {
  require_rollout(rollout, size());
  return (stepper_->flags(rollout) & rom::fatal_flags) == 0;
}

DecodedFields RolloutBatch::decode(int rollout, const std::vector<double>& X) const {
  require_rollout(rollout, size());
  require_points(X, "decode");
  std::vector<double> xhat, xhatdot;
  stepper_->latent_of(rollout, xhat, xhatdot);
  return mpmrom::decode(*model_, X, xhat, xhatdot);
}

DecodedFields RolloutBatch::decode_all(const std::vector<double>& X) const {
  require_points(X, "decode_all");
  std::vector<double> xhat, xhatdot;
  stepper_->latent(xhat, xhatdot);
  return mpmrom::decode(*model_, X, xhat, xhatdot);
}

DeviceArray RolloutBatch::latent_state_on_device() const { return stepper_->latent_on_device(false); }
DeviceArray RolloutBatch::latent_rate_on_device() const { return stepper_->latent_on_device(true); }

ReducedModel ReducedModel::load(const std::string& model_path, const std::string& scene_path, RomSettings settings) {
  settings.validate();
  ReducedModel rom;
  rom.model_ = std::make_shared<const Model>(load_model(model_path));
  rom.scene_ = load_scene(scene_path);
  rom.scene_path_ = scene_path;
  rom.settings_ = settings;
  rom.reduction_ = prepare_hyper_reduction(*rom.model_, rom.scene_, settings, nullptr, {});
  rom.names_ = rom.scene_.design.names;
  if (rom.names_.empty())
    for (const auto& [name, value] : rom.scene_.parameters) rom.names_.push_back(name);
  return rom;
}

RolloutBatch ReducedModel::batch(const std::vector<std::vector<double>>& parameter_values) const {
  std::vector<RolloutCase> cases;
  for (const auto& values : parameter_values) cases.push_back({values, ""});
  return RolloutBatch(model_, scene_path_, names_, cases, settings_, reduction_);
}

}  // namespace mpmrom
