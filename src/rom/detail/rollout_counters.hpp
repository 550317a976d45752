// The batch's per-rollout device counters (the detectors' flags, Algorithm 2's inversion failures and fallbacks, the
// projection's regularised steps and largest condition estimate): their allocation, their place in a checkpoint
// (BatchState) and in the outcomes. Private to the rom stage.
#pragma once

#include <Kokkos_Core.hpp>

#include <string>
#include <vector>

#include "manifold/device_data.hpp"
#include "rom/detail/batch_stepper_base.hpp"

namespace mpmrom::impl {

// values (in memory order) into view through one host mirror.
template <class View, class Values>
void fill_view(const View& view, const Values& values) {
  const auto host = Kokkos::create_mirror_view(view);
  using Value = typename View::non_const_value_type;
  for (std::size_t i = 0; i < values.size(); ++i) host.data()[i] = Value(values[i]);
  Kokkos::deep_copy(view, host);
}

// The View's values in memory order, as ints.
template <class View>
std::vector<int> download_ints(const View& view) {
  const auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
  return std::vector<int>(host.data(), host.data() + host.size());
}

template <class MemorySpace>
struct RolloutCounters {
  Kokkos::View<int*, MemorySpace> flags, failures, step_failures, fallbacks, regularized;  // step_failures: this step's
  Kokkos::View<real_t*, MemorySpace> max_condition;

  explicit RolloutCounters(int rollouts)
      : flags("mpmrom::rom::flags", rollouts),
        failures("mpmrom::rom::failures", rollouts),
        step_failures("mpmrom::rom::step_failures", rollouts),
        fallbacks("mpmrom::rom::fallbacks", rollouts),
        regularized("mpmrom::rom::regularized", rollouts),
        max_condition("mpmrom::rom::max_condition", rollouts) {}

  std::size_t rollouts() const { return flags.extent(0); }

  void save(BatchState& saved) const {
    saved.max_condition = download(max_condition);
    saved.flags = download_ints(flags);
    saved.failures = download_ints(failures);
    saved.fallbacks = download_ints(fallbacks);
    saved.regularized = download_ints(regularized);
  }

  // Whether saved holds counters of this many rollouts.
  bool fits(const BatchState& saved) const {
    const std::size_t B = rollouts();
    return saved.max_condition.size() == B && saved.flags.size() == B && saved.failures.size() == B &&
           saved.fallbacks.size() == B && saved.regularized.size() == B;
  }

  void restore(const BatchState& saved) {
    fill_view(max_condition, saved.max_condition);
    fill_view(flags, saved.flags);
    fill_view(failures, saved.failures);
    fill_view(fallbacks, saved.fallbacks);
    fill_view(regularized, saved.regularized);
  }

  // The counters into each rollout's outcome.
  void report(std::vector<RolloutOutcome>& outcomes) const {
    const auto condition = download(max_condition);
    const auto regularized_steps = download_ints(regularized), failed = download_ints(failures),
               fell_back = download_ints(fallbacks);
    for (std::size_t b = 0; b < outcomes.size(); ++b) {
      outcomes[b].max_condition = condition[b];
      outcomes[b].regularized_steps = regularized_steps[b];
      outcomes[b].inversion_failures = failed[b];
      outcomes[b].inversion_fallbacks = fell_back[b];
    }
  }
};

}  // namespace mpmrom::impl
