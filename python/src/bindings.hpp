// The Python module mpmrom._core (nanobind): what each binding file adds, and the errors it raises.
#pragma once

#include <nanobind/nanobind.h>
#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>

namespace mpmrom::python {

// mpmrom.Error (a RuntimeError): the program's or the library's one-line message.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// mpmrom.SimulationFailed (an Error): a full-order run failed (the program's exit status 3).
struct SimulationFailed : Error {
  using Error::Error;
};

// A JSON value as the Python object json.loads makes of it.
nanobind::object json_to_python(const nlohmann::json& value);

void bind_session(nanobind::module_& m);   // module.cpp: initialize, runtime_info, version
void bind_commands(nanobind::module_& m);  // commands.cpp: run_command
void bind_rollouts(nanobind::module_& m);  // rollouts.cpp: RomSettings, ReducedModel, RolloutBatch, Outcome

}  // namespace mpmrom::python
