// Wall-clock timing shared by every stage (progress lines, benchmark records).
#pragma once

#include <chrono>

namespace mpmrom {

using SteadyClock = std::chrono::steady_clock;

// Seconds elapsed since start, on the steady clock.
inline double seconds_since(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

}  // namespace mpmrom
