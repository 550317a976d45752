#include "mpmrom/model.hpp"

#include <cmath>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/hdf5_file.hpp"
#include "io/file_checks.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "mpmrom/runtime.hpp"

namespace mpmrom {
namespace {

using impl::bad;
using impl::checked_integers;
using impl::read_checked;
using impl::require_finite;
using impl::shape_string;

constexpr hdf5::Element stored_element = hdf5::element_of<real_t>();

// Checks the model's own consistency before anything is written.
void check_model(const std::string& path, const Model& m) {
  nn::MlpLayout layout;
  try {
    layout = m.layout();
  } catch (const std::invalid_argument& e) {
    bad(path, std::string("invalid architecture: ") + e.what());
  }
  if (m.weights.size() != std::size_t(layout.num_params))
    bad(path, "model has " + std::to_string(m.weights.size()) + " weights, the architecture needs " +
                  std::to_string(layout.num_params));
  const std::size_t codes = m.num_codes();
  if (m.codes.size() != codes * m.latent_dim || m.code_run.size() != codes || m.code_time.size() != codes)
    bad(path, "latent codes, their runs and their times disagree in number");
  for (const auto run : m.code_run)
    if (run < 0 || std::size_t(run) >= m.runs.size()) bad(path, "a latent code names a run that is not listed");
  const std::size_t n = m.num_points();
  if (n == 0 || m.X.size() != 3 * n || m.volume.size() != n) bad(path, "reference configuration shapes disagree");
  require_finite(path, "weights", m.weights.data(), {m.weights.size()});
  require_finite(path, "codes", m.codes.data(), {m.codes.size()});
  require_finite(path, "X", m.X.data(), {n, 3});
  for (const auto p : m.sample_ranking)
    if (p < 0 || std::size_t(p) >= n) bad(path, "the sample ranking names a point that does not exist");
  if (m.projection_weights.size() != m.projection_samples.size())
    bad(path, "the stored projection samples and weights differ in number");
  for (const auto p : m.projection_samples)
    if (p < 0 || std::size_t(p) >= n) bad(path, "the stored projection samples name a point that does not exist");
  for (const double w : m.projection_weights)
    if (!(w > 0) || !std::isfinite(w)) bad(path, "the stored projection weights must be positive and finite");
  for (const double w : m.projection_sensitivities)
    if (!(w >= 0) || !std::isfinite(w))
      bad(path, "the stored projection set's sensitivity weights must be finite and >= 0");
  for (int d = 0; d < 3; ++d)
    if (!(m.standardization.input_scale[d] > 0) || !(m.standardization.output_scale[d] > 0))
      bad(path, "standardisation scales must be positive");
}

template <class T>
void write_dataset(hdf5::Group& group, const std::string& name, hdf5::Element type, const std::vector<T>& values,
                   const std::vector<std::size_t>& shape) {
  auto dataset = group.create_dataset(name, type, shape);
  if (impl::product(shape) > 0) dataset.write(values.data());
}

void write_stored(hdf5::Group& group, const std::string& name, const std::vector<double>& values,
                  const std::vector<std::size_t>& shape) {
  std::vector<real_t> stored(values.begin(), values.end());
  write_dataset(group, name, stored_element, stored, shape);
}

std::vector<double> three(const double* values) { return {values[0], values[1], values[2]}; }

// /samples (optional, from mpmrom train): the greedy ranking, the greedy projection's set and its weights.
void read_samples(const std::string& path, const hdf5::Group& samples, std::size_t n, Model& m) {
  const auto indices = [&](const std::string& name) {
    const hdf5::Dataset dataset = samples.dataset(name);
    const auto shape = dataset.shape();
    if (shape.size() != 1 || shape[0] == 0 || shape[0] > n)
      bad(path, "dataset /samples/" + name + " has shape " + shape_string(shape) + ", expected (1 to " +
                    std::to_string(n) + " samples)");
    return checked_integers<std::int64_t>(path, "/samples/" + name, read_checked(path, dataset, shape, ""), 0,
                                          double(n - 1));
  };
  if (samples.has_child("greedy_ranking")) m.sample_ranking = indices("greedy_ranking");
  if (!samples.has_child("projection_samples")) return;
  m.projection_samples = indices("projection_samples");
  m.projection_weights = read_checked(path, samples.dataset("projection_weights"), {m.projection_samples.size()},
                                      "(one per stored projection sample)");
  // absent in files written before the selection tried sets weighing the increments' response: the increments alone
  if (samples.has_child("projection_sensitivities")) {
    const hdf5::Dataset dataset = samples.dataset("projection_sensitivities");
    const auto shape = dataset.shape();
    if (shape.size() != 1 || shape[0] == 0 || shape[0] > 64)
      bad(path, "dataset /samples/projection_sensitivities has shape " + shape_string(shape) + ", expected (1 to 64)");
    m.projection_sensitivities = read_checked(path, dataset, shape, "");
  }
}

}  // namespace

void save_model(const std::string& path, const Model& m, const OptimizerState* optimizer) {
  check_model(path, m);
  const std::size_t codes = m.num_codes(), n = m.num_points();
  AtomicFile out(path);
  {
    hdf5::File file = hdf5::File::create(out.temporary_path());
    impl::write_file_identity(file, model_format, model_format_version);
    file.set_string_attribute("scene_name", m.scene_name);
    file.set_string_attribute("scene", m.scene_text);
    file.set_string_attribute("settings", m.settings.dump());
    file.set_string_attribute("errors", m.errors.dump());

    hdf5::Group network = file.create_group("network");
    network.set_string_attribute("activation", "elu");
    network.set_string_attribute("output", "displacement");
    network.set_integer_attribute("latent_dim", m.latent_dim);
    network.set_integer_attribute("width", m.width);
    network.set_integer_attribute("depth", m.depth);
    write_stored(network, "params", m.weights, {m.weights.size()});
    const auto& s = m.standardization;
    write_dataset(network, "input_mean", hdf5::Element::float64, three(s.input_mean), {3});
    write_dataset(network, "input_scale", hdf5::Element::float64, three(s.input_scale), {3});
    write_dataset(network, "output_mean", hdf5::Element::float64, three(s.output_mean), {3});
    write_dataset(network, "output_scale", hdf5::Element::float64, three(s.output_scale), {3});
    network.set_double_attribute("loss_position_scale", m.loss_scales[0]);
    network.set_double_attribute("loss_gradient_scale", m.loss_scales[1]);
    network.set_double_attribute("loss_velocity_scale", m.loss_scales[2]);
    network.set_double_attribute("loss_affine_scale", m.loss_scales[3]);

    hdf5::Group latent = file.create_group("codes");
    latent.set_string_list_attribute("runs", m.runs);
    write_stored(latent, "values", m.codes, {codes, std::size_t(m.latent_dim)});
    write_dataset(latent, "run", hdf5::Element::int64, m.code_run, {codes});
    write_dataset(latent, "time", hdf5::Element::float64, m.code_time, {codes});

    hdf5::Group reference = file.create_group("reference");
    write_stored(reference, "X", m.X, {n, 3});
    write_stored(reference, "mass", m.mass, {n});
    write_stored(reference, "volume", m.volume, {n});

    if (!m.sample_ranking.empty() || !m.projection_samples.empty()) {
      hdf5::Group samples = file.create_group("samples");
      if (!m.sample_ranking.empty())
        write_dataset(samples, "greedy_ranking", hdf5::Element::int64, m.sample_ranking, {m.sample_ranking.size()});
      if (!m.projection_samples.empty()) {
        const std::size_t count = m.projection_samples.size();
        write_dataset(samples, "projection_samples", hdf5::Element::int64, m.projection_samples, {count});
        write_dataset(samples, "projection_weights", hdf5::Element::float64, m.projection_weights, {count});
        write_dataset(samples, "projection_sensitivities", hdf5::Element::float64, m.projection_sensitivities,
                      {m.projection_sensitivities.size()});
      }
    }

    if (optimizer) {
      const std::size_t total = m.weights.size() + m.codes.size();
      if (optimizer->first_moment.size() != total || optimizer->second_moment.size() != total)
        bad(path, "optimiser state does not cover the weights and codes");
      hdf5::Group opt = file.create_group("optimizer");
      // Moments in double whatever the build: a resumed run must continue bit for bit.
      write_dataset(opt, "first_moment", hdf5::Element::float64, optimizer->first_moment, {total});
      write_dataset(opt, "second_moment", hdf5::Element::float64, optimizer->second_moment, {total});
      opt.set_integer_attribute("step", optimizer->step);
      opt.set_integer_attribute("epoch", optimizer->epoch);
    }
    file.set_integer_attribute("complete", 1);
    file.close();
  }
  out.commit();
}

Model load_model(const std::string& path, OptimizerState* optimizer) {
  // Version 1 differs in its string attributes only (variable-length), which the HDF5 layer refuses unless trusted.
  const hdf5::File file = impl::open_checked(
      path, {model_format, model_format_version, "model", "no such model file", "not an mpmrom model file",
             "incomplete model file (training did not finish writing it)"});

  Model m;
  m.precision = file.string_attribute("precision");
  m.scene_name = file.string_attribute("scene_name");
  m.scene_text = file.string_attribute("scene");
  try {
    m.settings = nlohmann::json::parse(file.string_attribute("settings"));
    m.errors = nlohmann::json::parse(file.string_attribute("errors"));
  } catch (const nlohmann::json::exception&) {
    bad(path, "the settings or errors attribute is not valid JSON");
  }
  const hdf5::Group network = file.group("network");
  if (network.string_attribute("activation") != "elu" || network.string_attribute("output") != "displacement")
    bad(path, "network is not an ELU perceptron predicting the displacement");
  m.latent_dim = int(network.integer_attribute("latent_dim"));
  m.width = int(network.integer_attribute("width"));
  m.depth = int(network.integer_attribute("depth"));
  nn::MlpLayout layout;
  try {
    layout = m.layout();
  } catch (const std::invalid_argument& e) {
    bad(path, std::string("invalid architecture: ") + e.what());
  }
  const std::string arch = "for latent dimension " + std::to_string(m.latent_dim) + ", width " +
                           std::to_string(m.width) + " and depth " + std::to_string(m.depth);
  m.weights = read_checked(path, network.dataset("params"), {std::size_t(layout.num_params)}, arch);
  auto read3 = [&](const char* name, double* out) {
    const auto values = read_checked(path, network.dataset(name), {3}, "");
    for (int d = 0; d < 3; ++d) out[d] = values[d];
  };
  read3("input_mean", m.standardization.input_mean);
  read3("input_scale", m.standardization.input_scale);
  read3("output_mean", m.standardization.output_mean);
  read3("output_scale", m.standardization.output_scale);
  m.loss_scales[0] = network.double_attribute("loss_position_scale");
  m.loss_scales[1] = network.double_attribute("loss_gradient_scale");
  m.loss_scales[2] = network.double_attribute("loss_velocity_scale");
  if (network.has_attribute("loss_affine_scale")) m.loss_scales[3] = network.double_attribute("loss_affine_scale");

  const hdf5::Group latent = file.group("codes");
  m.runs = latent.string_list_attribute("runs");
  const auto code_shape = latent.dataset("values").shape();
  if (code_shape.size() != 2 || code_shape[1] != std::size_t(m.latent_dim))
    bad(path, "dataset /codes/values has shape " + shape_string(code_shape) + ", expected (snapshots, " +
                  std::to_string(m.latent_dim) + ")");
  const std::size_t codes = code_shape[0];
  m.codes = read_checked(path, latent.dataset("values"), code_shape, "");
  const auto runs = read_checked(path, latent.dataset("run"), {codes}, "(one per code)");
  m.code_run = checked_integers<std::int64_t>(path, "/codes/run", runs, 0);
  m.code_time = read_checked(path, latent.dataset("time"), {codes}, "(one per code)");

  const hdf5::Group reference = file.group("reference");
  const auto X_shape = reference.dataset("X").shape();
  if (X_shape.size() != 2 || X_shape[1] != 3 || X_shape[0] == 0)
    bad(path, "dataset /reference/X has shape " + shape_string(X_shape) + ", expected (points, 3)");
  const std::size_t n = X_shape[0];
  m.X = read_checked(path, reference.dataset("X"), {n, 3}, "");
  m.mass = read_checked(path, reference.dataset("mass"), {n}, "(one per point)");
  m.volume = read_checked(path, reference.dataset("volume"), {n}, "(one per point)");
  if (file.has_child("samples")) read_samples(path, file.group("samples"), n, m);
  check_model(path, m);

  if (optimizer) {
    if (!file.has_child("optimizer")) bad(path, "not a training checkpoint (no optimiser state)");
    const hdf5::Group opt = file.group("optimizer");
    const std::size_t total = m.weights.size() + m.codes.size();
    optimizer->first_moment = read_checked(path, opt.dataset("first_moment"), {total}, "(weights and codes)");
    optimizer->second_moment = read_checked(path, opt.dataset("second_moment"), {total}, "(weights and codes)");
    optimizer->step = opt.integer_attribute("step");
    optimizer->epoch = opt.integer_attribute("epoch");
  }
  return m;
}

}  // namespace mpmrom
