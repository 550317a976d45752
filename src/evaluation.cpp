#include "evaluation.hpp"

#include <cmath>
#include <stdexcept>

#include "rom.hpp"

namespace mpmrom {
namespace {

bool same_parameters(const std::vector<std::string>& names, const std::vector<double>& values,
                     const SnapshotHeader& header) {
  for (std::size_t k = 0; k < names.size(); ++k) {
    bool found = false;
    for (const auto& [name, value] : header.parameters)
      if (name == names[k]) {
        found = std::fabs(value - values[k]) <= 1e-9 * std::max(1.0, std::fabs(value));
        break;
      }
    if (!found) return false;
  }
  return true;
}

}  // namespace

ErrorAccumulator rollout_errors(const Model& model, const Snapshot& reference, const std::vector<double>& xhat,
                                const std::vector<double>& xhatdot) {
  const std::size_t P = reference.num_points, frames = xhat.size() / std::size_t(model.latent_dim);
  if (frames > reference.num_frames) throw std::invalid_argument("the rollout has more frames than its reference");
  const DecodedFields fields = decode(model, reference.X, xhat, xhatdot);
  double centroid[3] = {0, 0, 0};
  for (std::size_t p = 0; p < P; ++p)
    for (int d = 0; d < 3; ++d) centroid[d] += reference.X[3 * p + d] / double(P);
  ErrorAccumulator errors;
  for (std::size_t f = 0; f < frames; ++f)
    for (std::size_t p = 0; p < P; ++p) {
      const std::size_t i = f * P + p;
      errors.add(centroid, &reference.X[3 * p], &reference.x[3 * i], &fields.x[3 * i], &reference.v[3 * i],
                 &fields.v[3 * i], &reference.F[9 * i], &fields.F[9 * i]);
    }
  return errors;
}

nlohmann::json evaluate_rom(const RomFile& rom, const Model& model, const TrainingData& references) {
  const RomResult& res = rom.result;
  const std::size_t frames = res.times.size(), r = std::size_t(res.latent_dim);
  struct Candidate {
    const Snapshot* run;
    const std::string* file;
    const char* split;
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < references.train.runs.size(); ++i)
    candidates.push_back({&references.train.runs[i], &references.train.files[i], "train"});
  for (std::size_t i = 0; i < references.test.runs.size(); ++i)
    candidates.push_back({&references.test.runs[i], &references.test.files[i], "test"});

  ErrorAccumulator all, train, test;
  nlohmann::json runs = nlohmann::json::array();
  std::size_t matched = 0, stopped = 0;
  for (std::size_t b = 0; b < res.cases.size(); ++b) {
    const Candidate* match = nullptr;
    for (const auto& c : candidates)
      if (same_parameters(res.parameter_names, res.cases[b].values, c.run->header)) {
        match = &c;
        break;
      }
    nlohmann::json entry = {{"rollout", b}, {"parameters", nlohmann::json::object()}};
    for (std::size_t k = 0; k < res.parameter_names.size(); ++k)
      entry["parameters"][res.parameter_names[k]] = res.cases[b].values[k];
    const RolloutOutcome& outcome = res.outcomes[b];
    if (!outcome.message.empty()) entry["message"] = outcome.message;
    if (match == nullptr) {
      entry["reference"] = nullptr;
      runs.push_back(entry);
      continue;
    }
    const Snapshot& ref = *match->run;
    // A shorter rollout (--end-time) is compared on its own output times, which must be the reference's first ones.
    if (ref.num_frames < frames)
      throw std::runtime_error(*match->file + ": " + std::to_string(ref.num_frames) + " output times, the rollouts have " +
                               std::to_string(frames));
    for (std::size_t f = 0; f < frames; ++f)
      if (std::fabs(ref.time[f] - res.times[f]) > 1e-9 * std::max(1.0, std::fabs(res.times.back())))
        throw std::runtime_error(*match->file + ": output time " + std::to_string(f) + " is " +
                                 std::to_string(ref.time[f]) + " s, the rollouts' is " + std::to_string(res.times[f]) +
                                 " s");
    if (ref.num_points != model.num_points())
      throw std::runtime_error(*match->file + ": " + std::to_string(ref.num_points) +
                               " material points, the model has " + std::to_string(model.num_points()));
    const std::vector<double> xhat(res.xhat.begin() + b * frames * r, res.xhat.begin() + (b + 1) * frames * r);
    const std::vector<double> xhatdot(res.xhatdot.begin() + b * frames * r,
                                      res.xhatdot.begin() + (b + 1) * frames * r);
    const ErrorAccumulator errors = rollout_errors(model, ref, xhat, xhatdot);
    const std::string split = res.cases[b].split.empty() ? match->split : res.cases[b].split;
    entry["reference"] = *match->file;
    entry["split"] = split;
    entry["errors"] = to_json(errors.metrics());
    entry["completed"] = outcome.frames_completed == int(frames);
    runs.push_back(entry);
    ++matched;
    if (outcome.frames_completed != int(frames)) ++stopped;
    all.merge(errors);
    (split == "test" ? test : train).merge(errors);
  }
  if (matched == 0)
    throw std::runtime_error("no rollout matches a reference run with the same parameter values");
  nlohmann::json out = to_json(all.metrics());
  out["rollouts"] = res.cases.size();
  out["matched"] = matched;
  out["stopped"] = stopped;
  out["train"] = to_json(train.metrics());
  out["test"] = to_json(test.metrics());
  out["runs"] = runs;
  return out;
}

}  // namespace mpmrom
