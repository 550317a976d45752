#include <stdexcept>
#include <string>
#include <vector>

#include "bench/bench.hpp"
#include "core/timing.hpp"
#include "mpmrom/rollout_batch.hpp"
#include "rom/scene_points.hpp"

namespace mpmrom {

RomBenchmark bench_rom(const Model& model, const Scene& scene, RomSettings settings, int rollouts, int frames,
                       int warmup) {
  if (rollouts < 1 || frames < 1 || warmup < 0)
    throw std::invalid_argument("bench rom: rollouts and frames must be positive, warmup non-negative");
  const auto start = SteadyClock::now();
  const Model moved = model_at_scene_points(model, scene);
  settings.selection = SampleSelection::Random;
  settings.weighting = SampleWeighting::Mass;
  const HyperReduction reduction =
      build_hyper_reduction(moved, scene, settings, select_samples(moved, scene, settings, nullptr));
  std::vector<std::string> names = scene.design.names;
  if (names.empty())
    for (const auto& [name, value] : scene.parameters) names.push_back(name);
  RolloutCase only;
  for (const auto& name : names) only.values.push_back(scene.parameters.at(name));
  RolloutBatch batch(moved, scene.source_path, names, std::vector<RolloutCase>(std::size_t(rollouts), only), settings,
                     reduction);
  if (warmup + frames >= batch.frames())
    throw std::invalid_argument("bench rom: " + std::to_string(warmup) + " warm-up and " + std::to_string(frames) +
                                " timed output intervals, but the scene has " + std::to_string(batch.frames() - 1));
  RomBenchmark result;
  result.setup_seconds = seconds_since(start);
  for (int f = 0; f < warmup; ++f) batch.advance();
  const long steps_before = batch.steps();
  const auto timed = SteadyClock::now();
  for (int f = 0; f < frames; ++f) batch.advance();
  result.seconds = seconds_since(timed);
  result.steps = batch.steps() - steps_before;
  result.particles = moved.num_points();
  result.model_points = model.num_points();
  result.samples = int(reduction.samples.size());
  result.rollouts = rollouts;
  result.frames = frames;
  result.settings = settings;
  for (int b = 0; b < rollouts; ++b) result.stopped_rollouts += !batch.running(b);
  return result;
}

}  // namespace mpmrom
