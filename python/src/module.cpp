// mpmrom._core: the compiled half of the Python package (python/mpmrom/ is the other). Kokkos starts on the first call
// that needs it and stops at interpreter exit (session.hpp).
#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>

#include "bindings.hpp"
#include "common.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/runtime.hpp"
#include "session.hpp"

namespace nb = nanobind;

namespace mpmrom::python {

nb::object json_to_python(const nlohmann::json& value) {
  return nb::module_::import_("json").attr("loads")(value.dump());
}

void bind_session(nb::module_& m) {
  m.attr("__version__") = MPMROM_VERSION_STRING;
  m.attr("precision") = MPMROM_PRECISION_NAME;
  m.def("initialize", &initialize, nb::arg("threads") = 0, nb::arg("device") = -1,
        "Starts Kokkos with `threads` CPU threads (0: OMP_NUM_THREADS or every core) on GPU `device` (-1: the "
        "first). Optional: the first call that needs Kokkos starts it with the defaults. Once per process, before "
        "anything else runs.");
  m.def(
      "runtime_info",
      [] {
        require_kokkos();
        return json_to_python(cli::to_json(runtime_info()));  // the program's `info --json`
      },
      "What this process runs on: backend, threads, device, Kokkos version, precision, mpmrom version and commit.");
  // After every Python object that could still hold a batch has had its chance to go, batches free their Views.
  nb::module_::import_("atexit").attr("register")(nb::cpp_function(&finalize));
}

}  // namespace mpmrom::python

NB_MODULE(_core, m) {
  using namespace mpmrom::python;
  // Tried in the reverse order of registration: the library's other runtime errors become mpmrom.Error last.
  static PyObject* error_type = nullptr;
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const std::runtime_error& e) {
      PyErr_SetString(error_type, e.what());
    }
  });
  error_type = nb::exception<Error>(m, "Error", PyExc_RuntimeError).ptr();
  nb::exception<SimulationFailed>(m, "SimulationFailed", error_type);
  bind_session(m);
  bind_commands(m);
  bind_rollouts(m);
}
