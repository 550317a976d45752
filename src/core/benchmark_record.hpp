// The identity every benchmark record carries (SPEC.md: device, backend, threads, precision, versions).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace mpmrom {

// A benchmark record with the runtime's identity (device, backend, threads, precision, versions) filled in.
nlohmann::json benchmark_record(const std::string& benchmark, const std::string& scene);

}  // namespace mpmrom
