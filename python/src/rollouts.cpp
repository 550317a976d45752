// The deployment API (include/mpmrom/rollout_batch.hpp) in Python: RomSettings, ReducedModel, RolloutBatch and each
// rollout's Outcome. Arrays go out as NumPy arrays that own the vectors the library returned (moved, not copied), so
// they outlive the batch; arrays come in as C-contiguous float64 (python/mpmrom/ converts and checks them). Latent
// states can also stay in the device's memory, handed out through DLPack.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/unique_ptr.h>
#include <nanobind/stl/vector.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mpmrom/rollout_batch.hpp"
#include "session.hpp"

namespace nb = nanobind;

namespace mpmrom::python {
namespace {

using InArray = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using OutArray = nb::ndarray<nb::numpy, double>;

// A NumPy array that owns `values` (moved into it), shaped `shape`.
OutArray to_numpy(std::vector<double>&& values, const std::vector<std::size_t>& shape) {
  auto* owned = new std::vector<double>(std::move(values));
  nb::capsule owner(owned, [](void* p) noexcept { delete static_cast<std::vector<double>*>(p); });
  return OutArray(owned->data(), shape.size(), shape.data(), owner);
}

// Holds a DeviceArray's memory for the Python objects that use it; frees it at interpreter exit, before Kokkos is
// finalised, even where a framework (a torch tensor, say) still refers to it then.
class DeviceMemoryOwner {
 public:
  explicit DeviceMemoryOwner(std::shared_ptr<const void> memory) : memory_(std::move(memory)) {
    register_device_owner(this, [this] { memory_.reset(); });
  }
  ~DeviceMemoryOwner() { unregister_device_owner(this); }
  DeviceMemoryOwner(const DeviceMemoryOwner&) = delete;
  DeviceMemoryOwner& operator=(const DeviceMemoryOwner&) = delete;

 private:
  std::shared_ptr<const void> memory_;
};

// A DLPack-capable array (nanobind.nb_ndarray: __dlpack__, __dlpack_device__) over the device array's memory.
nb::ndarray<nb::array_api> to_dlpack(DeviceArray&& array) {
  auto* owner = new DeviceMemoryOwner(std::move(array.owner));
  nb::capsule capsule(owner, [](void* p) noexcept { delete static_cast<DeviceMemoryOwner*>(p); });
  const std::vector<std::size_t> shape(array.shape.begin(), array.shape.end());
  return nb::ndarray<nb::array_api>(const_cast<void*>(array.data), shape.size(), shape.data(), capsule, nullptr,
                                    array.bits == 32 ? nb::dtype<float>() : nb::dtype<double>(),
                                    array.dlpack_device_type, array.device_id);
}

// Rows of an (n, columns) array, each value finite; `what` names the array in the error.
std::vector<std::vector<double>> rows_of(const InArray& a, std::size_t columns, const char* what) {
  if (a.shape(1) != columns)
    throw nb::value_error(
        (std::string(what) + " must have " + std::to_string(columns) + " columns, not " + std::to_string(a.shape(1)))
            .c_str());
  std::vector<std::vector<double>> rows(a.shape(0), std::vector<double>(columns));
  for (std::size_t i = 0; i < a.shape(0); ++i)
    for (std::size_t j = 0; j < columns; ++j) {
      rows[i][j] = a(i, j);
      if (!std::isfinite(rows[i][j]))
        throw nb::value_error(
            (std::string(what) + ": row " + std::to_string(i) + ", column " + std::to_string(j) + " is not finite")
                .c_str());
    }
  return rows;
}

// Reference points (n, 3), row-major.
std::vector<double> points_of(const InArray& X) {
  std::vector<double> flat;
  for (const auto& p : rows_of(X, 3, "points")) flat.insert(flat.end(), p.begin(), p.end());
  return flat;
}

// Decoded fields as the tuple (x, v, F) of NumPy arrays, shaped (leading..., 3) and (leading..., 3, 3).
nb::tuple fields_tuple(DecodedFields&& fields, std::vector<std::size_t> leading) {
  auto shaped = [&leading](std::vector<double>&& values, std::initializer_list<std::size_t> trailing) {
    std::vector<std::size_t> shape = leading;
    shape.insert(shape.end(), trailing);
    return to_numpy(std::move(values), shape);
  };
  return nb::make_tuple(shaped(std::move(fields.x), {3}), shaped(std::move(fields.v), {3}),
                        shaped(std::move(fields.F), {3, 3}));
}

// A RolloutBatch that frees its device memory at interpreter exit (session.hpp) or on free(), after which every
// call raises mpmrom.Error.
class Batch {
 public:
  explicit Batch(RolloutBatch&& batch) : batch_(std::make_unique<RolloutBatch>(std::move(batch))) {
    register_device_owner(this, [this] { batch_.reset(); });
  }
  ~Batch() { unregister_device_owner(this); }
  Batch(const Batch&) = delete;
  Batch& operator=(const Batch&) = delete;

  RolloutBatch& get() const {
    if (!batch_) throw Error("this RolloutBatch was freed (free(), the end of its with-block, or interpreter exit)");
    return *batch_;
  }
  void free() { batch_.reset(); }

 private:
  std::unique_ptr<RolloutBatch> batch_;
};

template <class Enum>
void enum_property(nb::class_<RomSettings>& c, const char* name, Enum RomSettings::*member,
                   Enum (*from_string)(const std::string&), std::string (*name_of)(Enum), const char* doc) {
  c.def_prop_rw(
      name, [member, name_of](const RomSettings& s) { return name_of(s.*member); },
      [member, from_string](RomSettings& s, const std::string& value) { s.*member = from_string(value); }, doc);
}

void bind_settings(nb::module_& m) {
  nb::class_<RomSettings> c(
      m, "RomSettings", "The reduced model's settings (docs/rom.md): the attributes are `mpmrom rollout`'s options");
  c.def(nb::init<>())
      .def_static(
          "defaults", [](const std::string& method) { return rom_defaults(rom_method_from_string(method)); },
          nb::arg("method"), "The measured defaults of a method: 'point', 'node' or 'galerkin'.")
      .def_rw("samples", &RomSettings::samples, "Sample points (0: every point)")
      .def_rw("selection_sensitivities", &RomSettings::selection_sensitivities)
      .def_rw("seed", &RomSettings::seed)
      .def_rw("cfl", &RomSettings::cfl, "0: the scene's")
      .def_rw("envelope_margin", &RomSettings::envelope_margin)
      .def_rw("quadrature_order", &RomSettings::quadrature_order)
      .def_rw("newton_tolerance", &RomSettings::newton_tolerance)
      .def_rw("newton_iterations", &RomSettings::newton_iterations)
      .def_rw("projection_iterations", &RomSettings::projection_iterations)
      .def_rw("rate_damping", &RomSettings::rate_damping)
      .def_rw("cubature_candidates", &RomSettings::cubature_candidates)
      .def_rw("cubature_runs", &RomSettings::cubature_runs)
      .def_rw("cubature_frames", &RomSettings::cubature_frames)
      .def_rw("galerkin_transfer", &RomSettings::galerkin_transfer)
      .def_rw("galerkin_node_average", &RomSettings::galerkin_node_average)
      .def_rw("max_condition", &RomSettings::max_condition)
      .def_rw("regularization", &RomSettings::regularization)
      .def_rw("regularize", &RomSettings::regularize)
      .def_rw("inversion_fallback", &RomSettings::inversion_fallback)
      .def_rw("max_failed_inversions", &RomSettings::max_failed_inversions)
      .def_rw("energy_growth", &RomSettings::energy_growth)
      .def_rw("end_time", &RomSettings::end_time, "Horizon (s); 0: the scene's end time")
      .def("validate", &RomSettings::validate, "Raises ValueError naming a bad setting")
      .def("to_dict", [](const RomSettings& s) { return json_to_python(s.to_json()); });
  enum_property(c, "method", &RomSettings::method, rom_method_from_string, to_string, "'point', 'node' or 'galerkin'");
  enum_property(c, "selection", &RomSettings::selection, sample_selection_from_string, to_string,
                "'greedy-projection', 'greedy', 'cubature', 'region' or 'random'");
  enum_property(c, "projection", &RomSettings::projection, projection_scheme_from_string, to_string,
                "'velocity' or 'position'");
  enum_property(c, "weights", &RomSettings::weighting, sample_weighting_from_string, to_string,
                "'auto', 'mass' or 'cubature'");
  enum_property(c, "cubature_snapshots", &RomSettings::snapshot_source, snapshot_source_from_string, to_string,
                "'reduced', 'states' or 'full'");
  enum_property(c, "cubature_target", &RomSettings::cubature_target, cubature_target_from_string, to_string,
                "'own' or 'grid'");
  enum_property(c, "galerkin_strain", &RomSettings::galerkin_strain, galerkin_strain_from_string, to_string,
                "'continuum' or 'grid'");
  enum_property(c, "integrator", &RomSettings::integrator, time_integrator_from_string, to_string,
                "'euler' or 'leapfrog'");
}

void bind_outcome(nb::module_& m) {
  nb::class_<RolloutOutcome>(m, "Outcome", "How a rollout went (docs/stability.md)")
      .def_ro("flags", &RolloutOutcome::flags)
      .def_ro("frames_completed", &RolloutOutcome::frames_completed)
      .def_ro("stopped_at", &RolloutOutcome::stopped_at, "Time of the failure (s), -1 if none")
      .def_ro("max_condition", &RolloutOutcome::max_condition)
      .def_ro("regularized_steps", &RolloutOutcome::regularized_steps)
      .def_ro("inversion_failures", &RolloutOutcome::inversion_failures)
      .def_ro("inversion_fallbacks", &RolloutOutcome::inversion_fallbacks)
      .def_ro("message", &RolloutOutcome::message, "Empty, or one line on what happened")
      .def_ro("warning", &RolloutOutcome::warning, "Empty, or one line: parameters outside the training range")
      .def("__repr__", [](const RolloutOutcome& o) {
        return "Outcome(frames_completed=" + std::to_string(o.frames_completed) +
               ", stopped_at=" + std::to_string(o.stopped_at) + ", message='" + o.message + "')";
      });
}

void bind_batch(nb::module_& m) {
  nb::class_<Batch>(m, "RolloutBatch",
                    "Rollouts of one model advanced together, output interval by output interval (docs/api.md)")
      .def_prop_ro(
          "size", [](const Batch& b) { return b.get().size(); }, "Rollouts")
      .def_prop_ro(
          "latent_dim", [](const Batch& b) { return b.get().latent_dim(); }, "r")
      .def_prop_ro(
          "frame", [](const Batch& b) { return b.get().frame(); }, "Output frame reached (0: initial)")
      .def_prop_ro("frames", [](const Batch& b) { return b.get().frames(); })
      .def_prop_ro(
          "time", [](const Batch& b) { return b.get().time(); }, "Time (s) of frame")
      .def_prop_ro(
          "times", [](const Batch& b) { return b.get().times(); }, "Every output time (s)")
      .def_prop_ro(
          "steps", [](const Batch& b) { return b.get().steps(); }, "Time steps taken so far")
      .def(
          "advance",
          [](Batch& b) {
            auto& batch = b.get();
            nb::gil_scoped_release no_gil;
            return batch.advance();
          },
          "Advances every running rollout to the next output time; False, doing nothing, at the horizon.")
      .def(
          "latent_state",
          [](const Batch& b) {
            auto& batch = b.get();
            return to_numpy(batch.latent_state(), {std::size_t(batch.size()), std::size_t(batch.latent_dim())});
          },
          "xhat now, (size, r)")
      .def(
          "latent_rate",
          [](const Batch& b) {
            auto& batch = b.get();
            return to_numpy(batch.latent_rate(), {std::size_t(batch.size()), std::size_t(batch.latent_dim())});
          },
          "xhatdot now, (size, r)")
      .def(
          "latent_state_on_device", [](const Batch& b) { return to_dlpack(b.get().latent_state_on_device()); },
          "xhat now, (size, r), in the device's memory and the build's precision, as a DLPack array")
      .def(
          "latent_rate_on_device", [](const Batch& b) { return to_dlpack(b.get().latent_rate_on_device()); },
          "xhatdot now, (size, r), in the device's memory and the build's precision, as a DLPack array")
      .def("outcomes", [](const Batch& b) { return b.get().outcomes(); })
      .def(
          "running", [](const Batch& b, int rollout) { return b.get().running(rollout); }, nb::arg("rollout"))
      .def(
          "decode",
          [](const Batch& b, int rollout, const InArray& X) {
            const auto flat = points_of(X);
            const std::size_t n = flat.size() / 3;
            return fields_tuple(b.get().decode(rollout, flat), {n});
          },
          nb::arg("rollout"), nb::arg("points"), "(x, v, F) of a rollout now at reference points (n, 3)")
      .def(
          "decode_all",
          [](const Batch& b, const InArray& X) {
            const auto flat = points_of(X);
            const std::size_t n = flat.size() / 3;
            auto& batch = b.get();
            auto fields = [&] {
              nb::gil_scoped_release no_gil;
              return batch.decode_all(flat);
            }();
            return fields_tuple(std::move(fields), {std::size_t(batch.size()), n});
          },
          nb::arg("points"), "(x, v, F) of every rollout now at reference points (n, 3): one network pass")
      .def("free", &Batch::free, "Frees the batch's memory now; every later call raises mpmrom.Error");
}

void bind_model(nb::module_& m) {
  nb::class_<ReducedModel>(m, "ReducedModel", "A trained model ready to run on its scene (docs/api.md)")
      .def(
          "__init__",
          [](ReducedModel* self, const std::string& model_path, const std::string& scene_path,
             const RomSettings& settings) {
            require_kokkos();
            auto loaded = [&] {
              nb::gil_scoped_release no_gil;  // a greedy selection may roll out its trial sets first
              return ReducedModel::load(model_path, scene_path, settings);
            }();
            new (self) ReducedModel(std::move(loaded));
          },
          nb::arg("model"), nb::arg("scene"), nb::arg("settings") = RomSettings{})
      .def_prop_ro("settings", &ReducedModel::settings)
      .def_prop_ro("parameter_names", &ReducedModel::parameter_names, "The order of a batch's parameter columns")
      .def_prop_ro("latent_dim", [](const ReducedModel& r) { return r.model().latent_dim; })
      .def_prop_ro(
          "samples", [](const ReducedModel& r) { return r.hyper_reduction().samples; },
          "Indices of the sample points into reference_points")
      .def(
          "reference_points",
          [](const ReducedModel& r) {
            auto X = r.reference_points();
            const std::size_t n = X.size() / 3;
            return to_numpy(std::move(X), {n, 3});
          },
          "The model's material points in the reference configuration, (n, 3)")
      .def(
          "batch",
          [](const ReducedModel& r, const InArray& values) {
            const auto rows = rows_of(values, r.parameter_names().size(), "parameter values");
            if (rows.empty()) throw nb::value_error("parameter values: a batch needs at least one row");
            require_kokkos();
            auto batch = [&] {
              nb::gil_scoped_release no_gil;
              return r.batch(rows);
            }();
            return std::make_unique<Batch>(std::move(batch));
          },
          nb::arg("values"), "One rollout per row of parameter values (columns in parameter_names order)");
}

}  // namespace

void bind_rollouts(nb::module_& m) {
  bind_settings(m);
  bind_outcome(m);
  bind_batch(m);
  bind_model(m);
}

}  // namespace mpmrom::python
