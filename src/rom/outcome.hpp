// What a rollout's outcome holds, field by field (for the code that writes or reads them all), and what its flags
// (rom/kernels/projection.hpp) mean, in words, for the rollout record and the studies.
#pragma once

#include <string>

#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// One field of RolloutOutcome: its name (as in the ROM file's /outcome, where the strings are lists named in the
// plural) and member; detector: set frame by frame by the stepper's detectors (the others: the safeguards' counters
// and the training-range warning).
template <class T>
struct OutcomeField {
  using type = T;
  const char* name;
  T RolloutOutcome::*member;
  bool detector;
};

// Calls visit(OutcomeField<T>) for every field of RolloutOutcome, in the order of its declaration.
template <class Visit>
void for_each_outcome_field(Visit&& visit) {
  visit(OutcomeField<int>{"flags", &RolloutOutcome::flags, true});
  visit(OutcomeField<int>{"frames_completed", &RolloutOutcome::frames_completed, true});
  visit(OutcomeField<double>{"stopped_at", &RolloutOutcome::stopped_at, true});
  visit(OutcomeField<double>{"max_condition", &RolloutOutcome::max_condition, false});
  visit(OutcomeField<long>{"regularized_steps", &RolloutOutcome::regularized_steps, false});
  visit(OutcomeField<long>{"inversion_failures", &RolloutOutcome::inversion_failures, false});
  visit(OutcomeField<long>{"inversion_fallbacks", &RolloutOutcome::inversion_fallbacks, false});
  visit(OutcomeField<std::string>{"message", &RolloutOutcome::message, true});
  visit(OutcomeField<std::string>{"warning", &RolloutOutcome::warning, false});
}

// One line naming the causes behind fatal rollout flags; with_remedies adds what to change for each, in brackets.
std::string describe_flags(int flags, bool with_remedies = false);

}  // namespace mpmrom::impl
