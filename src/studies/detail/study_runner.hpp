// What the pipeline's study and the stability map's study share: the scene of the design, loaded once, and reduced
// configurations on it (their settings, their hyper-reductions, batches of rollouts).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mpmrom/rom.hpp"

namespace mpmrom {

class StudyRunner {
 public:
  // selection: the study's sample selection, or (nullopt) each method's default (rom_defaults).
  StudyRunner(const std::string& scene_path, std::optional<SampleSelection> selection);

  const Scene& scene() const { return scene_; }
  const std::string& scene_path() const { return scene_path_; }
  const std::vector<std::string>& names() const { return scene_.design.names; }

  // A configuration with the study's sample selection (cfl 0: the scene's); the rest are the method's defaults.
  RomSettings rom_settings(RomMethod method, int samples, double cfl) const;
  // The hyper-reduction rom asks for on the scene (prepare_hyper_reduction; data: the training runs, where the
  // selection fits them); log receives its fits' lines.
  HyperReduction hyper_reduction(const Model& model, const RomSettings& rom, const TrainingData* data,
                                 const std::function<void(const std::string&)>& log = {}) const;
  // The greedy projection's snapshots for the model with RomSettings' defaults, kept for the model's next
  // configurations of the same step settings.
  const ProjectionSelector& default_selector(const Model& model) const;
  // The rollouts of cases (values in the order of names()) on the scene at scene_path: the design's or a variant.
  RomResult rollouts(const Model& model, const std::string& scene_path, const std::vector<RolloutCase>& cases,
                     const RomSettings& rom, const HyperReduction& reduction) const;

 private:
  std::string scene_path_;
  Scene scene_;
  std::optional<SampleSelection> selection_;
  // The greedy projection's snapshots of rom's step on model, kept for the next call with the same (the study's
  // training runs, data, do not change between calls).
  const ProjectionSelector& selector(const Model& model, const RomSettings& rom,
                                     const TrainingData* data = nullptr) const;
  // The last greedy projection snapshots and what they were gathered for (model checksum, step settings).
  mutable std::string selector_key_;
  mutable std::shared_ptr<const ProjectionSelector> selector_;
};

}  // namespace mpmrom
