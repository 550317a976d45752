// `mpmrom upgrade`: rewrites files of older mpmrom versions in the current formats. Snapshot format 1, model format 1
// and ROM formats 1 and 2 store their string attributes as variable-length strings, which libhdf5 1.10 reads without
// checks (a damaged file can hang or crash it); this build refuses them everywhere else. Upgrading reads such a file
// trusting it (hdf5::TrustLegacyStrings) and writes it again, atomically, with fixed-length strings.
#pragma once

#include <string>

namespace mpmrom {

// Upgrades the file at path in place (snapshot, model or training checkpoint, ROM file); returns one line saying
// what it did ("snapshot format 1 -> 2", or that it was current already). Throws std::runtime_error with one line
// when the file is of no kind it knows, damaged, or of another precision than this build's (it would be narrowed or
// widened).
std::string upgrade_file(const std::string& path);

}  // namespace mpmrom
