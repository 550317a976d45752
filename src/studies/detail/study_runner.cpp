// The studies' shared runner of reduced configurations (study_runner.hpp).
#include "studies/detail/study_runner.hpp"

#include "rom/rom_file.hpp"  // model_checksum

namespace mpmrom {

StudyRunner::StudyRunner(const std::string& scene_path, std::optional<SampleSelection> selection)
    : scene_path_(scene_path), scene_(load_scene(scene_path)), selection_(selection) {}

RomSettings StudyRunner::rom_settings(RomMethod method, int samples, double cfl) const {
  RomSettings rom = rom_defaults(method);
  rom.samples = samples;
  rom.cfl = cfl;
  if (selection_) rom.selection = *selection_;
  return rom;
}

HyperReduction StudyRunner::hyper_reduction(const Model& model, const RomSettings& rom, const TrainingData* data,
                                            const std::function<void(const std::string&)>& log) const {
  const auto cached = [this, &model, data](const RomSettings& fitted) -> const ProjectionSelector& {
    return selector(model, fitted, data);
  };
  return prepare_hyper_reduction(model, scene_, rom, data, log, cached);
}

const ProjectionSelector& StudyRunner::selector(const Model& model, const RomSettings& rom,
                                                const TrainingData* data) const {
  nlohmann::json step = rom.to_json();
  for (const char* choice : {"samples", "selection", "seed", "weights", "end_time"}) step.erase(choice);
  const std::string key = std::to_string(model_checksum(model)) + step.dump();
  if (!selector_ || key != selector_key_) {
    selector_ = std::make_shared<const ProjectionSelector>(model, cubature_snapshots(scene_, rom, data));
    selector_key_ = key;
  }
  return *selector_;
}

const ProjectionSelector& StudyRunner::default_selector(const Model& model) const {
  RomSettings rom;
  rom.selection = SampleSelection::GreedyProjection;
  return selector(model, rom);
}

RomResult StudyRunner::rollouts(const Model& model, const std::string& scene_path,
                                const std::vector<RolloutCase>& cases, const RomSettings& rom,
                                const HyperReduction& reduction) const {
  return run_rollouts(model, scene_path, scene_.design.names, cases, rom, reduction);
}

}  // namespace mpmrom
