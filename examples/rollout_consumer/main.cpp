// Deploys a trained mpmrom model from another program: loads it with its scene, runs a batch of reduced rollouts
// output interval by output interval, and prints each rollout's mean displacement and fastest point, decoded at the
// model's reference points.
//
//   rollout_consumer MODEL.h5 SCENE.toml [VALUES ...]
//
// Each VALUES is one rollout's parameter values, comma-separated in the order the program prints (the scene's
// [design] names); without any, one rollout runs at the scene's own values.
#include <mpmrom/rollout_batch.hpp>
#include <mpmrom/runtime.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

namespace {

std::vector<double> parse_values(const std::string& text) {
  std::vector<double> values;
  std::istringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    std::size_t used = 0;
    values.push_back(std::stod(item, &used));
    if (used != item.size()) throw std::invalid_argument("'" + item + "' is not a number");
  }
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s MODEL.h5 SCENE.toml [VALUES ...]\n", argv[0]);
    return 2;
  }
  try {
    mpmrom::KokkosSession kokkos;  // Kokkos lives as long as this object: create it before any batch
    const auto rom = mpmrom::ReducedModel::load(argv[1], argv[2]);
    std::vector<std::vector<double>> rollouts;
    for (int i = 3; i < argc; ++i) rollouts.push_back(parse_values(argv[i]));
    if (rollouts.empty()) {
      std::vector<double> values;
      for (const auto& name : rom.parameter_names()) values.push_back(rom.scene().parameters.at(name));
      rollouts.push_back(values);
    }
    std::printf("model: r = %d, %zu reference points; parameters:", rom.model().latent_dim,
                rom.reference_points().size() / 3);
    for (const auto& name : rom.parameter_names()) std::printf(" %s", name.c_str());
    std::printf("\n");

    auto batch = rom.batch(rollouts);
    const auto& X = rom.reference_points();
    const std::size_t n = X.size() / 3;
    do {
      std::printf("t = %.4f s", batch.time());
      for (int b = 0; b < batch.size(); ++b) {
        const auto fields = batch.decode(b, X);
        double displacement = 0, fastest = 0;
        for (std::size_t p = 0; p < n; ++p) {
          double d2 = 0, v2 = 0;
          for (int i = 0; i < 3; ++i) {
            d2 += std::pow(fields.x[3 * p + i] - X[3 * p + i], 2);
            v2 += std::pow(fields.v[3 * p + i], 2);
          }
          displacement += std::sqrt(d2) / double(n);
          fastest = std::max(fastest, std::sqrt(v2));
        }
        std::printf("  | rollout %d: mean displacement %.3e m, fastest %.3e m/s", b, displacement, fastest);
      }
      std::printf("\n");
    } while (batch.advance());

    int stopped = 0;
    const auto outcomes = batch.outcomes();
    for (std::size_t b = 0; b < outcomes.size(); ++b) {
      if (!outcomes[b].message.empty()) std::printf("rollout %zu: %s\n", b, outcomes[b].message.c_str());
      if (!outcomes[b].warning.empty()) std::printf("rollout %zu: warning: %s\n", b, outcomes[b].warning.c_str());
      stopped += batch.running(int(b)) ? 0 : 1;
    }
    std::printf("%d rollouts, %ld steps, %d stopped early\n", batch.size(), batch.steps(), stopped);
    return stopped == 0 ? 0 : 3;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "rollout_consumer: error: %s\n", error.what());
    return 1;
  }
}
