// How the ranks of an MPI batch (run_rollouts with a communicator) send their shares of the result to rank 0.
#pragma once

#include <string>

#include "mpmrom/rom.hpp"

namespace mpmrom::impl {

// A rank's share of a batch's result, as bytes for the gather to rank 0: trajectories and outcomes.
std::string share_bytes(const RomResult& share);
// Appends the trajectories and outcomes of a share (share_bytes) to whole, after those of the ranks before it.
void append_share(RomResult& whole, const std::string& bytes);

}  // namespace mpmrom::impl
