// What a rollout's outcome flags (rom/kernels/projection.hpp) mean, in words, for the rollout record and the studies.
#pragma once

#include <string>

namespace mpmrom::impl {

// One line naming the causes behind fatal rollout flags; with_remedies adds what to change for each, in brackets.
std::string describe_flags(int flags, bool with_remedies = false);

}  // namespace mpmrom::impl
