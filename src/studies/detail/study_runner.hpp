// What the pipeline's study and the stability map's study share: the scene of the design, loaded once, and reduced
// configurations on it (their settings, their hyper-reductions, batches of rollouts).
#pragma once

#include <string>
#include <vector>

#include "mpmrom/rom.hpp"

namespace mpmrom {

class StudyRunner {
 public:
  StudyRunner(const std::string& scene_path, SampleSelection selection);

  const Scene& scene() const { return scene_; }
  const std::string& scene_path() const { return scene_path_; }
  const std::vector<std::string>& names() const { return scene_.design.names; }

  // A configuration with the study's sample selection (cfl 0: the scene's); the rest are RomSettings' defaults.
  RomSettings rom_settings(RomMethod method, int samples, double cfl) const;
  // The samples of rom on the scene (fitted to data's training runs where the selection needs them) and the
  // hyper-reduction built on them.
  HyperReduction hyper_reduction(const Model& model, const RomSettings& rom, const TrainingData* data) const;
  // The rollouts of cases (values in the order of names()) on the scene at scene_path: the design's or a variant.
  RomResult rollouts(const Model& model, const std::string& scene_path, const std::vector<RolloutCase>& cases,
                     const RomSettings& rom, const HyperReduction& reduction) const;

 private:
  std::string scene_path_;
  Scene scene_;
  SampleSelection selection_;
};

}  // namespace mpmrom
