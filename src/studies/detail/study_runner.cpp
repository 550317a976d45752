// The studies' shared runner of reduced configurations (study_runner.hpp).
#include "studies/detail/study_runner.hpp"

namespace mpmrom {

StudyRunner::StudyRunner(const std::string& scene_path, SampleSelection selection)
    : scene_path_(scene_path), scene_(load_scene(scene_path)), selection_(selection) {}

RomSettings StudyRunner::rom_settings(RomMethod method, int samples, double cfl) const {
  RomSettings rom;
  rom.method = method;
  rom.samples = samples;
  rom.cfl = cfl;
  rom.selection = selection_;
  return rom;
}

HyperReduction StudyRunner::hyper_reduction(const Model& model, const RomSettings& rom,
                                            const TrainingData* data) const {
  const auto samples = select_samples(model, scene_, rom, data);
  return build_hyper_reduction(model, scene_, rom, samples);
}

RomResult StudyRunner::rollouts(const Model& model, const std::string& scene_path,
                                const std::vector<RolloutCase>& cases, const RomSettings& rom,
                                const HyperReduction& reduction) const {
  return run_rollouts(model, scene_path, scene_.design.names, cases, rom, reduction);
}

}  // namespace mpmrom
