// SplitMix64 (Steele, Lea and Flood 2014): a seeded stream that is the same on every platform (the standard
// library's distributions and shuffles are not), and its finaliser as a well-mixed hash.
#pragma once

#include <cstdint>

namespace mpmrom {

// The finaliser: a bijection of 64-bit words whose output bits each depend on every input bit.
inline std::uint64_t splitmix64_mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// The next draw of the stream whose state is `state` (advanced).
inline std::uint64_t splitmix64_next(std::uint64_t& state) { return splitmix64_mix(state += 0x9e3779b97f4a7c15ULL); }

}  // namespace mpmrom
