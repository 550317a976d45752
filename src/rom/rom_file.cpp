#include "rom/rom_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "io/atomic_file.hpp"
#include "io/hdf5_file.hpp"
#include "io/file_checks.hpp"
#include "io/xdmf.hpp"
#include "mpmrom/snapshot.hpp"
#include "rom/outcome.hpp"

namespace mpmrom {
namespace {

using impl::bad;

template <class T>
hdf5::Dataset write_dataset(hdf5::Group& group, const std::string& name, hdf5::Element type,
                            const std::vector<T>& values, const std::vector<std::size_t>& shape) {
  auto dataset = group.create_dataset(name, type, shape);
  if (impl::product(shape) > 0) dataset.write(values.data());
  return dataset;
}

// Views /xdmf/<array>/<rollout>/<frame> of the decoded fields and the side file's blocks, one per rollout (the first
// max_xdmf_rollouts: three views per rollout and frame would swamp the file, and ParaView, for large batches), named
// by its parameter values.
constexpr std::size_t max_xdmf_rollouts = 64;

std::vector<impl::XdmfBlock> write_decoded_views(hdf5::File& file, const RomResult& res, std::size_t num_points,
                                                 const std::vector<const hdf5::Dataset*>& sources) {
  const std::size_t B = std::min(res.cases.size(), max_xdmf_rollouts), frames = res.times.size();
  hdf5::Group xdmf = file.create_group("xdmf");
  impl::write_xdmf_vertices(xdmf, num_points);
  for (const hdf5::Dataset* source : sources) {
    hdf5::Group array = xdmf.create_group(source->path().substr(source->path().rfind('/') + 1));  // "x", "v", "F"
    for (std::size_t b = 0; b < B; ++b) {
      hdf5::Group rollout = array.create_group(std::to_string(b));
      for (std::size_t frame = 0; frame < frames; ++frame)
        rollout.create_entry_view(std::to_string(frame), *source, {b, frame});
    }
  }
  std::vector<impl::XdmfBlock> blocks;
  for (std::size_t b = 0; b < B; ++b) {
    std::string name = "rollout " + std::to_string(b);
    for (std::size_t k = 0; k < res.parameter_names.size(); ++k)
      name += (k == 0 ? " (" : ", ") + res.parameter_names[k] + " = " + impl::number_string(res.cases[b].values[k]) +
              (k + 1 == res.parameter_names.size() ? ")" : "");
    const std::string at = "/" + std::to_string(b);
    blocks.push_back({name,
                      "/xdmf/x" + at,
                      4,
                      {{"velocity", 3, 4, "/xdmf/v" + at, true},
                       {"F", 9, 4, "/xdmf/F" + at, true},
                       {"X", 3, 8, "/decoded/X", false}}});
  }
  return blocks;
}

std::vector<std::int64_t> to_int64(const std::vector<int>& values) { return {values.begin(), values.end()}; }

// /outcome: a dataset per field of RolloutOutcome (impl::for_each_outcome_field), an entry per rollout; the strings
// as lists named in the plural.
void write_outcomes(hdf5::File& file, const std::vector<RolloutOutcome>& outcomes) {
  hdf5::Group group = file.create_group("outcome");
  impl::for_each_outcome_field([&](const auto& field) {
    using Field = typename std::decay_t<decltype(field)>::type;
    std::vector<Field> column;
    for (const auto& o : outcomes) column.push_back(o.*field.member);
    if constexpr (std::is_same_v<Field, std::string>)
      group.create_string_list(std::string(field.name) + "s", column);
    else if constexpr (std::is_integral_v<Field>)
      write_dataset(group, field.name, hdf5::Element::int64, std::vector<std::int64_t>(column.begin(), column.end()),
                    {outcomes.size()});
    else
      write_dataset(group, field.name, hdf5::Element::float64, column, {outcomes.size()});
  });
}

// Throws when the parts of rom do not fit together (an internal error) or hold a non-finite value.
void check_rom(const std::string& path, const RomFile& rom) {
  const RomResult& res = rom.result;
  const std::size_t B = res.cases.size(), frames = res.times.size(), r = std::size_t(res.latent_dim);
  if (res.xhat.size() != B * frames * r || res.xhatdot.size() != B * frames * r || res.outcomes.size() != B)
    bad(path, "inconsistent reduced-model result (internal error)");
  impl::require_finite(path, "xhat", res.xhat.data(), {res.xhat.size()});
  impl::require_finite(path, "xhatdot", res.xhatdot.data(), {res.xhatdot.size()});
  const HyperReduction& sets = rom.sets;
  if (sets.quadrature_x.size() != 3 * sets.quadrature_weight.size() ||
      (!sets.node_offsets.empty() && sets.node_offsets.size() != sets.nodes.size() + 1))
    bad(path, "inconsistent hyper-reduction sets (internal error)");
  const std::size_t n = rom.decoded_X.size() / 3;
  if (n > 0) {
    if (rom.decoded_x.size() != B * frames * n * 3 || rom.decoded_v.size() != B * frames * n * 3 ||
        rom.decoded_F.size() != B * frames * n * 9)
      bad(path, "inconsistent decoded fields (internal error)");
    impl::require_finite(path, "decoded x", rom.decoded_x.data(), {rom.decoded_x.size()});
    impl::require_finite(path, "decoded v", rom.decoded_v.data(), {rom.decoded_v.size()});
    impl::require_finite(path, "decoded F", rom.decoded_F.data(), {rom.decoded_F.size()});
  }
}

// /hyper_reduction: the precomputed sets.
void write_hyper_reduction(hdf5::File& file, const HyperReduction& sets) {
  hdf5::Group reduction = file.create_group("hyper_reduction");
  write_dataset(reduction, "source_points", hdf5::Element::int64, to_int64(sets.source_points),
                {sets.source_points.size()});
  write_dataset(reduction, "nodes", hdf5::Element::int64, to_int64(sets.nodes), {sets.nodes.size()});
  write_dataset(reduction, "node_offsets", hdf5::Element::int64, to_int64(sets.node_offsets),
                {sets.node_offsets.size()});
  write_dataset(reduction, "node_sources", hdf5::Element::int64, to_int64(sets.node_sources),
                {sets.node_sources.size()});
  write_dataset(reduction, "quadrature_x", hdf5::Element::float64, sets.quadrature_x,
                {sets.quadrature_weight.size(), 3});
  write_dataset(reduction, "quadrature_weight", hdf5::Element::float64, sets.quadrature_weight,
                {sets.quadrature_weight.size()});
  // absent: the projection weighted the samples by their masses
  if (!sets.weights.empty())
    write_dataset(reduction, "sample_weights", hdf5::Element::float64, sets.weights, {sets.weights.size()});
  if (!sets.force_weights.empty())  // absent: the Galerkin forces weighted as the samples
    write_dataset(reduction, "sample_force_weights", hdf5::Element::float64, sets.force_weights,
                  {sets.force_weights.size()});
  if (sets.stable_time_step > 0)  // absent: no bound on the step but the CFL number's
    write_dataset(reduction, "stable_time_step", hdf5::Element::float64, std::vector<double>{sets.stable_time_step},
                  {1});
}

// The sets in /hyper_reduction (write_hyper_reduction) for the given samples.
HyperReduction read_hyper_reduction(const std::string& path, const hdf5::Group& reduction,
                                    const std::vector<int>& samples) {
  const auto indices = [&](const char* name) {
    const auto shape = reduction.dataset(name).shape();
    if (shape.size() != 1) bad(path, std::string("/hyper_reduction/") + name + " must be a vector");
    return impl::checked_integers<int>(path, std::string("/hyper_reduction/") + name,
                                       impl::read_checked(path, reduction.dataset(name), shape, ""), 0);
  };
  HyperReduction sets;
  sets.samples = samples;
  sets.source_points = indices("source_points");
  sets.nodes = indices("nodes");
  sets.node_offsets = indices("node_offsets");
  sets.node_sources = indices("node_sources");
  const auto weight_shape = reduction.dataset("quadrature_weight").shape();
  if (weight_shape.size() != 1) bad(path, "/hyper_reduction/quadrature_weight must be a vector");
  sets.quadrature_weight = impl::read_checked(path, reduction.dataset("quadrature_weight"), weight_shape, "");
  sets.quadrature_x =
      impl::read_checked(path, reduction.dataset("quadrature_x"), {weight_shape[0], 3}, "(quadrature points, 3)");
  if (!sets.node_offsets.empty() &&
      (sets.node_offsets.size() != sets.nodes.size() + 1 || sets.node_offsets.front() != 0 ||
       std::size_t(sets.node_offsets.back()) != sets.node_sources.size()))
    bad(path, "/hyper_reduction/node_offsets does not match nodes and node_sources");
  if (reduction.has_child("sample_weights"))
    sets.weights = impl::read_checked(path, reduction.dataset("sample_weights"), {samples.size()}, "(samples)");
  if (reduction.has_child("sample_force_weights"))
    sets.force_weights =
        impl::read_checked(path, reduction.dataset("sample_force_weights"), {samples.size()}, "(samples)");
  if (reduction.has_child("stable_time_step")) {
    sets.stable_time_step = impl::read_checked(path, reduction.dataset("stable_time_step"), {1}, "(1)")[0];
    if (!(sets.stable_time_step > 0)) bad(path, "/hyper_reduction/stable_time_step must be positive");
  }
  return sets;
}

// Version 1 kept the per-rollout strings in attributes, which HDF5 caps at 64 kB (about 10^4 rollouts).
std::vector<std::string> per_rollout_strings(const hdf5::Group& group, const std::string& name, std::int64_t version) {
  return version == 1 ? group.string_list_attribute(name) : group.dataset(name).read_strings();
}

// The B outcomes in /outcome (write_outcomes) of a file of the given version with the given number of frames.
std::vector<RolloutOutcome> read_outcomes(const std::string& path, const hdf5::Group& group, std::size_t B,
                                          std::size_t frames, std::int64_t version) {
  // Files written before the stability safeguards have no warnings or fallbacks: none to report.
  const auto absent = [&](const std::string& name) {
    return (name == "warning" && !(version > 1 || group.has_attribute("warnings"))) ||
           (name == "inversion_fallbacks" && !group.has_child(name));
  };
  std::vector<RolloutOutcome> outcomes(B);
  impl::for_each_outcome_field([&](const auto& field) {
    using Field = typename std::decay_t<decltype(field)>::type;
    const std::string name = field.name;
    if (absent(name)) return;
    std::vector<Field> column;
    if constexpr (std::is_same_v<Field, std::string>) {
      column = per_rollout_strings(group, name + "s", version);
      if (column.size() != B) bad(path, "/outcome " + name + "s: one per rollout expected");
    } else {
      const auto values = impl::read_checked(path, group.dataset(name), {B}, "(one per rollout)");
      if constexpr (std::is_integral_v<Field>)
        column = impl::checked_integers<Field>(path, "/outcome/" + name, values, 0,
                                               name == "frames_completed" ? double(frames) : INFINITY);
      else
        column = values;
    }
    for (std::size_t b = 0; b < B; ++b) outcomes[b].*field.member = column[b];
  });
  return outcomes;
}

// A settings key as its command-line flag spells it.
std::string flag_name(std::string key) {
  std::replace(key.begin(), key.end(), '_', '-');
  return key;
}

}  // namespace

std::uint64_t model_checksum(const Model& model) {
  std::uint64_t hash = 1469598103934665603ULL;
  for (const double w : model.weights) {
    unsigned char bytes[sizeof(double)];
    std::memcpy(bytes, &w, sizeof(double));
    for (const unsigned char c : bytes) hash = (hash ^ c) * 1099511628211ULL;
  }
  return hash;
}

void save_rom(const std::string& path, const RomFile& rom) {
  const RomResult& res = rom.result;
  const std::size_t B = res.cases.size(), frames = res.times.size(), r = std::size_t(res.latent_dim);
  const std::size_t names = res.parameter_names.size();
  check_rom(path, rom);
  const std::size_t n = rom.decoded_X.size() / 3;
  if (n > 0 && xdmf_path_for(path) == path)
    bad(path, "a ROM file cannot have the extension .xmf of its XDMF side file");
  AtomicFile out(path);
  std::vector<impl::XdmfBlock> blocks;
  {
    hdf5::File file = hdf5::File::create(out.temporary_path());
    impl::write_file_identity(file, rom_format, rom_format_version);
    file.set_string_attribute("scene_name", rom.scene_name);
    file.set_string_attribute("scene", rom.scene_text);
    file.set_string_attribute("model_path", rom.model_path);
    file.set_string_attribute("model_checksum", std::to_string(rom.model_checksum));
    file.set_string_attribute("settings", rom.settings.dump());
    file.set_string_attribute("hyper_reduction", rom.hyper_reduction.dump());
    file.set_string_attribute("timing", rom.timing.dump());

    hdf5::Group parameters = file.create_group("parameters");
    parameters.set_string_list_attribute("names", res.parameter_names);
    std::vector<double> values;
    std::vector<std::string> splits;
    for (const auto& c : res.cases) {
      values.insert(values.end(), c.values.begin(), c.values.end());
      splits.push_back(c.split);
    }
    parameters.create_string_list("split", splits);
    write_dataset(parameters, "values", hdf5::Element::float64, values, {B, names});

    hdf5::Group latent = file.create_group("latent");
    latent.set_integer_attribute("steps", res.steps);
    write_dataset(latent, "time", hdf5::Element::float64, res.times, {frames});
    write_dataset(latent, "xhat", hdf5::Element::float64, res.xhat, {B, frames, r});
    write_dataset(latent, "xhatdot", hdf5::Element::float64, res.xhatdot, {B, frames, r});

    write_outcomes(file, res.outcomes);

    hdf5::Group samples = file.create_group("samples");
    write_dataset(samples, "indices", hdf5::Element::int64, to_int64(rom.samples), {rom.samples.size()});
    write_hyper_reduction(file, rom.sets);

    if (n > 0) {
      hdf5::Group decoded = file.create_group("decoded");
      write_dataset(decoded, "X", hdf5::Element::float64, rom.decoded_X, {n, 3});
      const std::vector<float> x(rom.decoded_x.begin(), rom.decoded_x.end());
      const std::vector<float> v(rom.decoded_v.begin(), rom.decoded_v.end());
      const std::vector<float> F(rom.decoded_F.begin(), rom.decoded_F.end());
      const auto x_set = write_dataset(decoded, "x", hdf5::Element::float32, x, {B, frames, n, 3});
      const auto v_set = write_dataset(decoded, "v", hdf5::Element::float32, v, {B, frames, n, 3});
      const auto F_set = write_dataset(decoded, "F", hdf5::Element::float32, F, {B, frames, n, 3, 3});
      blocks = write_decoded_views(file, res, n, {&x_set, &v_set, &F_set});
    }
    file.set_integer_attribute("complete", 1);
  }
  if (n == 0) {
    out.commit();
    return;
  }
  // Decoded fields get an XDMF side file (ParaView opens the batch as a time series, a block per rollout); it goes
  // first, so that a ROM file under its final name always has it.
  const std::string h5_name = std::filesystem::path(path).filename().string();
  write_file_atomically(xdmf_path_for(path),
                        impl::xdmf_text(h5_name, rom.scene_name + " (reduced model)", n, res.times, blocks));
  out.commit();
}

RomFile load_rom(const std::string& path) {
  std::int64_t version = 0;
  // Versions 1 and 2 store variable-length string attributes (refused by the HDF5 layer unless trusted); version 1
  // also keeps the per-rollout strings as attributes.
  const hdf5::File file = impl::open_checked(path,
                                             {rom_format, rom_format_version, "ROM", "no such file",
                                              "not an mpmrom reduced-model (ROM) file", "incomplete ROM file"},
                                             &version);
  for (const char* group : {"parameters", "latent", "outcome", "samples"})
    if (!file.has_child(group)) bad(path, std::string("missing group /") + group);
  RomFile rom;
  rom.scene_name = file.string_attribute("scene_name");
  rom.scene_text = file.string_attribute("scene");
  rom.model_path = file.string_attribute("model_path");
  try {
    rom.model_checksum = std::stoull(file.string_attribute("model_checksum"));
    rom.settings = nlohmann::json::parse(file.string_attribute("settings"));
    rom.hyper_reduction = nlohmann::json::parse(file.string_attribute("hyper_reduction"));
    rom.timing = nlohmann::json::parse(file.string_attribute("timing"));
  } catch (const std::exception&) {
    bad(path, "the model checksum, settings, hyper_reduction or timing attribute is malformed");
  }
  RomResult& res = rom.result;
  const hdf5::Group parameters = file.group("parameters");
  res.parameter_names = parameters.string_list_attribute("names");
  const auto splits = per_rollout_strings(parameters, "split", version);
  const std::size_t B = splits.size(), names = res.parameter_names.size();
  const auto values = impl::read_checked(path, parameters.dataset("values"), {B, names}, "(rollouts, parameters)");
  for (std::size_t b = 0; b < B; ++b)
    res.cases.push_back({std::vector<double>(values.begin() + b * names, values.begin() + (b + 1) * names), splits[b]});

  const hdf5::Group latent = file.group("latent");
  res.steps = latent.integer_attribute("steps");
  const auto time_shape = latent.dataset("time").shape();
  if (time_shape.size() != 1 || time_shape[0] == 0) bad(path, "/latent/time must be a non-empty vector");
  const std::size_t frames = time_shape[0];
  res.times = impl::read_checked(path, latent.dataset("time"), {frames}, "");
  const auto xhat_shape = latent.dataset("xhat").shape();
  if (xhat_shape.size() != 3 || xhat_shape[0] != B || xhat_shape[1] != frames || xhat_shape[2] < 1)
    bad(path, "/latent/xhat has shape " + impl::shape_string(xhat_shape) + ", expected (rollouts, frames, r)");
  const std::size_t r = xhat_shape[2];
  res.latent_dim = int(r);
  res.xhat = impl::read_checked(path, latent.dataset("xhat"), {B, frames, r}, "");
  res.xhatdot = impl::read_checked(path, latent.dataset("xhatdot"), {B, frames, r}, "(like xhat)");

  res.outcomes = read_outcomes(path, file.group("outcome"), B, frames, version);
  const hdf5::Group samples = file.group("samples");
  const auto sample_shape = samples.dataset("indices").shape();
  if (sample_shape.size() != 1) bad(path, "/samples/indices must be a vector");
  rom.samples = impl::checked_integers<int>(path, "/samples/indices",
                                            impl::read_checked(path, samples.dataset("indices"), sample_shape, ""), 0);
  if (file.has_child("hyper_reduction"))  // absent in files written before it existed
    rom.sets = read_hyper_reduction(path, file.group("hyper_reduction"), rom.samples);
  if (file.has_child("decoded")) {
    const hdf5::Group decoded = file.group("decoded");
    const auto X_shape = decoded.dataset("X").shape();
    if (X_shape.size() != 2 || X_shape[1] != 3) bad(path, "/decoded/X must have shape (points, 3)");
    const std::size_t n = X_shape[0];
    rom.decoded_X = impl::read_checked(path, decoded.dataset("X"), {n, 3}, "");
    rom.decoded_x = impl::read_checked(path, decoded.dataset("x"), {B, frames, n, 3}, "");
    rom.decoded_v = impl::read_checked(path, decoded.dataset("v"), {B, frames, n, 3}, "");
    rom.decoded_F = impl::read_checked(path, decoded.dataset("F"), {B, frames, n, 3, 3}, "");
  }
  return rom;
}

HyperReduction reduction_from_rom(const RomFile& rom, const std::string& path, const Model& model, const Scene& scene,
                                  const RomSettings& settings) {
  const auto refuse = [&path](const std::string& what) {
    throw std::runtime_error(path + ": its hyper-reduction is not this rollout's: " + what);
  };
  if (rom.model_checksum != model_checksum(model)) refuse("it ran another model (checksum differs)");
  if (rom.scene_text != scene.source_text) refuse("it ran another scene (the scene's text differs)");
  if (rom.hyper_reduction.value("samples", std::size_t(0)) != rom.samples.size() ||
      (rom.sets.source_points.empty() && rom.sets.quadrature_weight.empty() && settings.method != RomMethod::Galerkin))
    refuse("the file holds no hyper-reduction sets (written before they were stored, or incomplete)");
  for (const int p : rom.samples)
    if (std::size_t(p) >= model.num_points()) refuse("a sample is not a point of the model");
  // The CFL number of the offline fits (cubature_snapshots): the Galerkin step's are at most the scene's.
  const auto fitted_cfl = [&](const nlohmann::json& json) {
    const double cfl = json.value("cfl", 0.0) > 0 ? json.value("cfl", 0.0) : scene.cfl;
    return json.value("method", std::string()) == "galerkin" ? std::min(cfl, scene.cfl) : cfl;
  };
  nlohmann::json own = settings.to_json(), stored = rom.settings;
  if (fitted_cfl(own) != fitted_cfl(stored)) refuse("its fits ran at another time step (--cfl)");
  for (const char* free : {"end_time", "energy_growth", "cfl", "integrator"}) own.erase(free), stored.erase(free);
  if (settings.selection != SampleSelection::GreedyProjection)  // the others' samples do not depend on it
    own.erase("selection_sensitivities"), stored.erase("selection_sensitivities");
  // A setting added since the file was written counts at its default: what the builds before it did, but for a
  // default that changed the builds' behaviour (their selection weighed no sensitivity).
  nlohmann::json defaults = RomSettings{}.to_json();
  defaults["selection_sensitivities"] = std::vector<double>{0.0};
  for (const auto& [key, value] : own.items())
    if (stored.contains(key) ? stored[key] != value : !(defaults.contains(key) && defaults[key] == value))
      refuse("--" + flag_name(key) + " differs (" + (stored.contains(key) ? stored[key].dump() : "absent") +
             " there, " + value.dump() + " here)");
  HyperReduction reduction = rom.sets;
  reduction.samples = rom.samples;
  reduction.weight_misfits = rom.hyper_reduction.value("weight_misfits", std::vector<double>());
  reduction.weight_misfits_held_out = rom.hyper_reduction.value("weight_misfits_held_out", std::vector<double>());
  return reduction;
}

}  // namespace mpmrom
