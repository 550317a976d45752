#include "analysis/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "mpmrom/rom.hpp"

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

// For each query point, the index of the nearest of the points (both (n, 3)), by a uniform bin search.
std::vector<std::size_t> nearest_points(const std::vector<double>& points, const std::vector<double>& queries) {
  const std::size_t n = points.size() / 3;
  double lo[3], hi[3];
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = points[d];
  for (std::size_t p = 0; p < n; ++p)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], points[3 * p + d]);
      hi[d] = std::max(hi[d], points[3 * p + d]);
    }
  // about one point per bin
  double volume = 1;
  for (int d = 0; d < 3; ++d) volume *= std::max(hi[d] - lo[d], 1e-12);
  const double h = std::max(std::cbrt(volume / double(n)), 1e-12);
  long bins[3];
  for (int d = 0; d < 3; ++d) bins[d] = std::max(1L, long(std::ceil((hi[d] - lo[d]) / h)));
  const auto bin_of = [&](const double* x, int d) {
    return std::clamp(long(std::floor((x[d] - lo[d]) / h)), 0L, bins[d] - 1);
  };
  std::vector<std::size_t> start(std::size_t(bins[0] * bins[1] * bins[2]) + 1, 0), order(n);
  const auto flat = [&](long i, long j, long k) { return std::size_t((i * bins[1] + j) * bins[2] + k); };
  for (std::size_t p = 0; p < n; ++p)
    ++start[flat(bin_of(&points[3 * p], 0), bin_of(&points[3 * p], 1), bin_of(&points[3 * p], 2)) + 1];
  for (std::size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t p = 0; p < n; ++p)
    order[fill[flat(bin_of(&points[3 * p], 0), bin_of(&points[3 * p], 1), bin_of(&points[3 * p], 2))]++] = p;

  std::vector<std::size_t> nearest(queries.size() / 3);
  for (std::size_t q = 0; q < nearest.size(); ++q) {
    const double* x = &queries[3 * q];
    const long c[3] = {bin_of(x, 0), bin_of(x, 1), bin_of(x, 2)};
    double best = INFINITY;
    // grow a shell of bins until no unsearched bin can hold a closer point
    for (long ring = 0; ring <= std::max({bins[0], bins[1], bins[2]}); ++ring) {
      if (std::isfinite(best) && (ring - 1) * h > std::sqrt(best)) break;
      for (long i = c[0] - ring; i <= c[0] + ring; ++i)
        for (long j = c[1] - ring; j <= c[1] + ring; ++j)
          for (long k = c[2] - ring; k <= c[2] + ring; ++k) {
            if (std::max({std::labs(i - c[0]), std::labs(j - c[1]), std::labs(k - c[2])}) != ring) continue;
            if (i < 0 || j < 0 || k < 0 || i >= bins[0] || j >= bins[1] || k >= bins[2]) continue;
            const std::size_t b = flat(i, j, k);
            for (std::size_t s = start[b]; s < start[b + 1]; ++s) {
              const double* y = &points[3 * order[s]];
              const double d2 =
                  (x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) + (x[2] - y[2]) * (x[2] - y[2]);
              if (d2 < best) {
                best = d2;
                nearest[q] = order[s];
              }
            }
          }
    }
  }
  return nearest;
}

ErrorAccumulator merged(const std::vector<ErrorAccumulator>& parts) {
  ErrorAccumulator all;
  for (const auto& part : parts) all.merge(part);
  return all;
}

}  // namespace

ErrorAccumulator resolution_errors(const Snapshot& reference, const Snapshot& run) {
  if (run.num_frames != reference.num_frames)
    throw std::runtime_error("the run has " + std::to_string(run.num_frames) + " output times, its reference " +
                             std::to_string(reference.num_frames));
  return merged(resolution_errors_by_frame(reference, run));
}

std::vector<ErrorAccumulator> resolution_errors_by_frame(const Snapshot& reference, const Snapshot& run) {
  if (run.num_frames > reference.num_frames)
    throw std::runtime_error("the run has " + std::to_string(run.num_frames) +
                             " output times, more than its "
                             "reference's " +
                             std::to_string(reference.num_frames));
  for (std::size_t f = 0; f < run.num_frames; ++f)
    if (std::fabs(run.time[f] - reference.time[f]) > 1e-9 * std::max(1.0, std::fabs(reference.time[f])))
      throw std::runtime_error("output time " + std::to_string(f) + " differs from the reference's");
  if (run.C.size() != run.F.size()) throw std::invalid_argument("resolution_errors needs the run's C (APIC)");
  const std::size_t P = reference.num_points, Q = run.num_points;
  const auto nearest = nearest_points(run.X, reference.X);
  double centroid[3] = {0, 0, 0};
  for (std::size_t p = 0; p < P; ++p)
    for (int d = 0; d < 3; ++d) centroid[d] += reference.X[3 * p + d] / double(P);
  std::vector<ErrorAccumulator> errors(run.num_frames);
  for (std::size_t f = 0; f < run.num_frames; ++f)
    for (std::size_t p = 0; p < P; ++p) {
      const std::size_t q = nearest[p], i = f * P + p, j = f * Q + q;
      const double* F = &run.F[9 * j];
      const double* C = &run.C[9 * j];
      double dX[3], dx[3], x[3], v[3];
      for (int d = 0; d < 3; ++d) dX[d] = reference.X[3 * p + d] - run.X[3 * q + d];
      for (int a = 0; a < 3; ++a) dx[a] = F[3 * a] * dX[0] + F[3 * a + 1] * dX[1] + F[3 * a + 2] * dX[2];
      for (int a = 0; a < 3; ++a) {
        x[a] = run.x[3 * j + a] + dx[a];
        v[a] = run.v[3 * j + a] + C[3 * a] * dx[0] + C[3 * a + 1] * dx[1] + C[3 * a + 2] * dx[2];
      }
      errors[f].add(centroid, &reference.X[3 * p], &reference.x[3 * i], x, &reference.v[3 * i], v, &reference.F[9 * i],
                    F);
    }
  return errors;
}

ErrorAccumulator rollout_errors(const Model& model, const Snapshot& reference, const std::vector<double>& xhat,
                                const std::vector<double>& xhatdot) {
  return merged(rollout_errors_by_frame(model, reference, xhat, xhatdot));
}

std::vector<ErrorAccumulator> rollout_errors_by_frame(const Model& model, const Snapshot& reference,
                                                      const std::vector<double>& xhat,
                                                      const std::vector<double>& xhatdot) {
  const std::size_t P = reference.num_points, frames = xhat.size() / std::size_t(model.latent_dim);
  if (frames > reference.num_frames) throw std::invalid_argument("the rollout has more frames than its reference");
  const DecodedFields fields = decode(model, reference.X, xhat, xhatdot);
  double centroid[3] = {0, 0, 0};
  for (std::size_t p = 0; p < P; ++p)
    for (int d = 0; d < 3; ++d) centroid[d] += reference.X[3 * p + d] / double(P);
  std::vector<ErrorAccumulator> errors(frames);
  for (std::size_t f = 0; f < frames; ++f)
    for (std::size_t p = 0; p < P; ++p) {
      const std::size_t i = f * P + p;
      errors[f].add(centroid, &reference.X[3 * p], &reference.x[3 * i], &fields.x[3 * i], &reference.v[3 * i],
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
  std::vector<ErrorAccumulator> by_frame(frames);  // every matched rollout, frame by frame
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
      throw std::runtime_error(*match->file + ": " + std::to_string(ref.num_frames) +
                               " output times, the rollouts have " + std::to_string(frames));
    for (std::size_t f = 0; f < frames; ++f)
      if (std::fabs(ref.time[f] - res.times[f]) > 1e-9 * std::max(1.0, std::fabs(res.times.back())))
        throw std::runtime_error(*match->file + ": output time " + std::to_string(f) + " is " +
                                 std::to_string(ref.time[f]) + " s, the rollouts' is " + std::to_string(res.times[f]) +
                                 " s");
    if (ref.num_points != model.num_points())
      throw std::runtime_error(*match->file + ": " + std::to_string(ref.num_points) +
                               " material points, the model has " + std::to_string(model.num_points()));
    const std::vector<double> xhat(res.xhat.begin() + b * frames * r, res.xhat.begin() + (b + 1) * frames * r);
    const std::vector<double> xhatdot(res.xhatdot.begin() + b * frames * r, res.xhatdot.begin() + (b + 1) * frames * r);
    const std::vector<ErrorAccumulator> frame_errors = rollout_errors_by_frame(model, ref, xhat, xhatdot);
    for (std::size_t f = 0; f < frames; ++f) by_frame[f].merge(frame_errors[f]);
    const ErrorAccumulator errors = merged(frame_errors);
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
  if (matched == 0) throw std::runtime_error("no rollout matches a reference run with the same parameter values");
  nlohmann::json out = to_json(all.metrics());
  out["rollouts"] = res.cases.size();
  out["matched"] = matched;
  out["stopped"] = stopped;
  out["train"] = to_json(train.metrics());
  out["test"] = to_json(test.metrics());
  out["runs"] = runs;
  // How the error grows: each output time's errors over every matched rollout (the first frame is the projected
  // initial state).
  out["frames"] = nlohmann::json::array();
  for (std::size_t f = 0; f < frames; ++f) {
    nlohmann::json frame = to_json(by_frame[f].metrics());
    frame["time"] = res.times[f];
    out["frames"].push_back(frame);
  }
  return out;
}

}  // namespace mpmrom
