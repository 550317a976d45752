// Scene files (mpmrom/scene.hpp): the scene built from a file's table, one function per section, with every check and
// its error message; the parameter design's runs.
#include "mpmrom/scene.hpp"

#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "scene/detail/toml_reader.hpp"

namespace mpmrom {
namespace {

using impl::fail;
using impl::parse_box;
using impl::parse_contact;
using impl::TableReader;

// Parameters: defaults from [parameters], then the run's values.
std::map<std::string, double> read_parameters(const std::string& path, const toml::table& parsed,
                                              const std::map<std::string, double>* run_parameters) {
  std::map<std::string, double> parameters;
  if (const toml::table* p = parsed["parameters"].as_table()) {
    for (const auto& [key, node] : *p) {
      const auto value = node.value<double>();
      if (!value) fail(path, "[parameters] " + std::string(key.str()) + " must be a number");
      parameters[std::string(key.str())] = *value;
    }
  }
  if (run_parameters)
    for (const auto& [k, v] : *run_parameters) parameters[k] = v;
  return parameters;
}

// The --set overrides: a bare key sets a parameter, a dotted key an entry of changed_root (a copy of parsed, made
// on the first one). Snapshots store the scene text: with entries overridden, source_text becomes the table as
// changed so the text reproduces the run.
void apply_overrides(const std::string& path, const toml::table& parsed, const std::vector<std::string>& overrides,
                     std::map<std::string, double>& parameters, std::optional<toml::table>& changed_root,
                     std::string& source_text) {
  bool entries_changed = false;
  for (const auto& o : overrides) {
    const auto eq = o.find('=');
    if (eq == std::string::npos || eq == 0) throw std::runtime_error("--set expects key=value, got '" + o + "'");
    const std::string key = o.substr(0, eq), value = o.substr(eq + 1);
    if (key.find('.') == std::string::npos) {
      if (!parameters.count(key)) throw std::runtime_error("--set " + key + ": the scene has no such parameter");
      parameters[key] = impl::parse_override_number(key, value);
    } else {
      if (!changed_root) changed_root = parsed;
      impl::set_entry(*changed_root, key, value);
      entries_changed = true;
    }
  }
  if (entries_changed) {
    std::ostringstream changed;
    changed << "# " << path << " with --set " <<
        [&] {
          std::string list;
          for (const auto& o : overrides) list += (list.empty() ? "" : " ") + o;
          return list;
        }() << "\n"
            << *changed_root << "\n";
    source_text = changed.str();
  }
}

void read_material(TableReader& top, const std::string& path, Scene& scene) {
  TableReader r(top.table("material", true), path + " [material]", scene.parameters);
  const std::string model = r.string("model", "fixed_corotated");
  if (model == "fixed_corotated")
    scene.material.model = ElasticModelKind::FixedCorotated;
  else if (model == "neo_hookean")
    scene.material.model = ElasticModelKind::NeoHookean;
  else
    fail(path + " [material]", "model must be fixed_corotated or neo_hookean, not '" + model + "'");
  scene.material.youngs_modulus = r.required_number("youngs_modulus");
  scene.material.poisson_ratio = r.required_number("poisson_ratio");
  scene.material.density = r.required_number("density");
  r.check_all_used();
  if (!(scene.material.youngs_modulus > 0)) fail(path + " [material]", "youngs_modulus must be positive");
  if (!(scene.material.poisson_ratio > -1 && scene.material.poisson_ratio < 0.5))
    fail(path + " [material]", "poisson_ratio must lie in (-1, 0.5)");
  if (!(scene.material.density > 0)) fail(path + " [material]", "density must be positive");
}

void read_grid(TableReader& top, const std::string& path, Scene& scene) {
  const std::string where = path + " [grid]";
  TableReader r(top.table("grid", true), where, scene.parameters);
  scene.domain = parse_box(r, where);
  scene.dx = r.required_number("dx");
  scene.walls = parse_contact(r.string("walls", "separate"), where);
  r.check_all_used();
  if (!(scene.dx > 0)) fail(where, "dx must be positive");
  for (int d = 0; d < 3; ++d)
    if ((scene.domain.hi[d] - scene.domain.lo[d]) / scene.dx < 4)
      fail(where, "the domain must span at least 4 cells in every axis");
}

void read_time(TableReader& top, const std::string& path, Scene& scene) {
  const std::string where = path + " [time]";
  TableReader r(top.table("time", true), where, scene.parameters);
  scene.end_time = r.required_number("end_time");
  scene.num_outputs = r.integer<int>("outputs", 1, 1);
  scene.cfl = r.number("cfl", 0.3);
  scene.time_step = r.number("dt", 0);
  scene.max_cfl = r.number("max_cfl", 0);
  scene.energy_growth = r.number("energy_growth", 10);
  const std::string transfer = r.string("transfer", "apic");
  if (transfer == "apic")
    scene.transfer = TransferKind::APIC;
  else if (transfer == "pic")
    scene.transfer = TransferKind::PIC;
  else
    fail(where, "transfer must be apic or pic, not '" + transfer + "'");
  r.check_all_used();
  if (!(scene.end_time > 0)) fail(where, "end_time must be positive");
  // Above 1 the explicit scheme is beyond its stability limit: allowed for stability studies (docs/stability.md).
  if (!(scene.cfl > 0 && scene.cfl <= 10)) fail(where, "cfl must lie in (0, 10]");
  if (!(scene.time_step >= 0 && std::isfinite(scene.time_step))) fail(where, "dt must be >= 0 (0: from cfl)");
  if (!(scene.max_cfl >= 0 && scene.max_cfl <= 10)) fail(where, "max_cfl must lie in [0, 10] (0: no sub-stepping)");
  if (!(scene.energy_growth >= 0 && std::isfinite(scene.energy_growth)))
    fail(where, "energy_growth must be >= 0 (0: no energy check)");
}

void read_ground(TableReader& top, const std::string& path, Scene& scene) {
  if (!top.has("ground")) return;
  const std::string where = path + " [ground]";
  TableReader r(top.table("ground"), where, scene.parameters);
  scene.ground.enabled = true;
  scene.ground.height = r.required_number("height");
  scene.ground.contact = parse_contact(r.string("contact", "separate"), where);
  r.check_all_used();
}

// The specs of the array of tables [[name]] (none if the file has none), one read(reader, where, i) each.
template <class Spec, class Read>
std::vector<Spec> read_tables(const toml::array* list, const std::string& path, const std::string& name,
                              const std::map<std::string, double>& parameters, const Read& read) {
  std::vector<Spec> specs;
  if (!list) return specs;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const std::string where = path + " [[" + name + "]] " + std::to_string(i + 1);
    const toml::table* t = list->get(i)->as_table();
    if (!t) fail(where, "must be a table");
    TableReader r(*t, where, parameters);
    specs.push_back(read(r, where, i));
  }
  return specs;
}

// A body's shape, size and half extents.
void read_shape(TableReader& r, const std::string& where, BodySpec& b) {
  const std::string shape = r.string("shape", "", true);
  b.center = r.vec3("center", {}, true);
  if (shape == "box") {
    b.shape = ShapeKind::Box;
    const Vec3d size = r.vec3("size", {}, true);
    for (int d = 0; d < 3; ++d) {
      if (!(size[d] > 0)) fail(where, "box size must be positive");
      b.half_extents[d] = size[d] / 2;
    }
  } else if (shape == "cylinder") {
    b.shape = ShapeKind::Cylinder;
    b.radius = r.required_number("radius");
    b.height = r.required_number("height");
    if (!(b.radius > 0 && b.height > 0)) fail(where, "cylinder radius and height must be positive");
    b.half_extents = {b.radius, b.radius, b.height / 2};
  } else if (shape == "sphere") {
    b.shape = ShapeKind::Sphere;
    b.radius = r.required_number("radius");
    if (!(b.radius > 0)) fail(where, "sphere radius must be positive");
    b.half_extents = {b.radius, b.radius, b.radius};
  } else {
    fail(where, "shape must be box, cylinder or sphere, not '" + shape + "'");
  }
}

// How a body's material points are placed: explicit points, or a count or spacing (and seed) for the sampler.
void read_sampling(TableReader& r, const std::string& where, BodySpec& b) {
  const std::string sampling = r.string("sampling", "lattice");
  if (sampling == "lattice")
    b.sampling = SamplingKind::Lattice;
  else if (sampling == "poisson_disk")
    b.sampling = SamplingKind::PoissonDisk;
  else if (sampling == "points")
    b.sampling = SamplingKind::Explicit;
  else
    fail(where, "sampling must be lattice, poisson_disk or points, not '" + sampling + "'");
  if (b.sampling == SamplingKind::Explicit) {
    const toml::array* points = r.array("points");
    if (!points || points->empty()) fail(where, "points sampling needs points = [[dx, dy, dz], ...]");
    for (const auto& node : *points) {
      const toml::array* p = node.as_array();
      if (!p || p->size() != 3) fail(where, "each point must be an array of 3 numbers");
      b.points.push_back(
          {r.to_number(*p->get(0), "points"), r.to_number(*p->get(1), "points"), r.to_number(*p->get(2), "points")});
    }
  } else {
    b.count = r.integer<long>("count", 0, 0, 2e9);
    b.spacing = r.number("spacing", 0);
    b.seed = r.integer<unsigned>("seed", 1, 0);
    if ((b.count > 0) == (b.spacing > 0)) fail(where, "give exactly one of count or spacing (positive)");
    if (b.spacing < 0) fail(where, "spacing must be positive");
  }
}

// Body i (from 0) of the scene's grid.
BodySpec read_body(TableReader& r, const std::string& where, std::size_t i, const Scene& scene) {
  BodySpec b;
  b.name = r.string("name", "body" + std::to_string(i + 1));
  read_shape(r, where, b);
  read_sampling(r, where, b);
  b.velocity = r.vec3("velocity", {0, 0, 0});
  b.angular_velocity = r.vec3("angular_velocity", {0, 0, 0});
  r.check_all_used();
  for (int d = 0; d < 3; ++d) {
    // Quadratic B-splines reach 1.5 cells; walls act within 2 cells of the domain's faces.
    const double margin = 2 * scene.dx;
    if (b.center[d] - b.half_extents[d] < scene.domain.lo[d] + margin ||
        b.center[d] + b.half_extents[d] > scene.domain.hi[d] - margin)
      fail(where, "the body must lie inside the grid domain, at least 2 cells from its faces");
  }
  return b;
}

DirichletSpec read_dirichlet(TableReader& r, const std::string& where, std::size_t) {
  DirichletSpec d;
  d.region = parse_box(r, where);
  d.velocity = r.vec3("velocity", {0, 0, 0});
  d.start = r.number("start", 0);
  d.end = r.number("end", 1e300);
  r.check_all_used();
  if (!(d.start < d.end)) fail(where, "start must be before end");
  return d;
}

ForceSpec read_force(TableReader& r, const std::string& where, std::size_t) {
  ForceSpec f;
  f.region = parse_box(r, where);
  if (r.has("force") == r.has("magnitude")) fail(where, "give either force = [fx, fy, fz] or magnitude/theta/phi");
  if (r.has("force")) {
    f.force = r.vec3("force", {});
  } else {
    // Spherical: theta is the azimuth in the horizontal plane from +x, phi the angle below the horizontal
    // (a push that tilts downwards); both in degrees.
    const double magnitude = r.required_number("magnitude");
    const double theta = r.required_number("theta_deg") * M_PI / 180;
    const double phi = r.required_number("phi_deg") * M_PI / 180;
    f.force = {magnitude * std::cos(phi) * std::cos(theta), magnitude * std::cos(phi) * std::sin(theta),
               -magnitude * std::sin(phi)};
  }
  f.start = r.number("start", 0);
  f.end = r.number("end", 1e300);
  r.check_all_used();
  if (!(f.start < f.end)) fail(where, "start must be before end");
  return f;
}

// A full-factorial design: every other key of [design] is a parameter with its levels.
void read_factorial_design(TableReader& r, const toml::table& t, const std::string& where, Scene& scene) {
  for (const auto& [key, node] : t) {
    const std::string name(key.str());
    if (name == "kind" || name == "test") continue;
    if (!scene.parameters.count(name)) fail(where, "'" + name + "' is not a parameter of the scene");
    const toml::array* levels = node.as_array();
    if (!levels || levels->empty()) fail(where, "'" + name + "' must be a non-empty array of levels");
    std::vector<double> values;
    for (const auto& level : *levels) values.push_back(r.to_number(level, name));
    r.mark_used(name);
    scene.design.names.push_back(name);
    scene.design.levels.push_back(values);
  }
}

// A list design: names = [...] and one row of values per run.
void read_list_design(TableReader& r, const std::string& where, Scene& scene) {
  const toml::array* names = r.array("names");
  const toml::array* runs = r.array("runs");
  if (!names || !runs) fail(where, "a list design needs names = [...] and runs = [[...], ...]");
  for (const auto& n : *names) {
    const auto s = n.value<std::string>();
    if (!s || !scene.parameters.count(*s)) fail(where, "names must list parameters of the scene");
    scene.design.names.push_back(*s);
  }
  for (const auto& run : *runs) {
    const toml::array* values = run.as_array();
    if (!values || values->size() != scene.design.names.size()) fail(where, "each run needs one value per name");
    std::vector<double> row;
    for (const auto& v : *values) row.push_back(r.to_number(v, "runs"));
    scene.design.runs.push_back(row);
  }
}

void read_design(TableReader& top, const std::string& path, Scene& scene) {
  if (!top.has("design")) return;
  const std::string where = path + " [design]";
  TableReader r(top.table("design"), where, scene.parameters);
  const std::string kind = r.string("kind", "full_factorial");
  const toml::table& t = top.table("design");
  if (kind == "full_factorial")
    read_factorial_design(r, t, where, scene);
  else if (kind == "list")
    read_list_design(r, where, scene);
  else
    fail(where, "kind must be full_factorial or list, not '" + kind + "'");
  const std::size_t num_runs = scene.design.all_runs().size();
  if (const toml::array* test = r.array("test")) {
    for (const auto& v : *test) {
      const double index = r.to_number(v, "test");
      scene.design.test_runs.push_back(r.whole<int>(index, "each test run index", 0, double(num_runs) - 1));
    }
  }
  r.check_all_used();
}

}  // namespace

namespace impl {

Scene build_scene(const std::string& path, const std::string& text, const toml::table& parsed,
                  const std::vector<std::string>& overrides, const std::map<std::string, double>* run_parameters) {
  std::optional<toml::table> changed_root;
  Scene scene;
  scene.source_text = text;
  scene.source_path = path;
  scene.parameters = read_parameters(path, parsed, run_parameters);
  apply_overrides(path, parsed, overrides, scene.parameters, changed_root, scene.source_text);
  const toml::table& root = changed_root ? *changed_root : parsed;

  TableReader top(root, path, scene.parameters);
  top.mark_used("parameters");
  scene.name = top.string("name", "", true);
  read_material(top, path, scene);
  read_grid(top, path, scene);
  read_time(top, path, scene);
  scene.gravity = top.vec3("gravity", {0, 0, 0});
  read_ground(top, path, scene);
  const toml::array* bodies = top.array("body");
  if (!bodies || bodies->empty()) fail(path, "needs at least one [[body]]");
  scene.bodies = read_tables<BodySpec>(
      bodies, path, "body", scene.parameters,
      [&](TableReader& r, const std::string& where, std::size_t i) { return read_body(r, where, i, scene); });
  scene.dirichlet =
      read_tables<DirichletSpec>(top.array("dirichlet"), path, "dirichlet", scene.parameters, read_dirichlet);
  scene.forces = read_tables<ForceSpec>(top.array("force"), path, "force", scene.parameters, read_force);
  read_design(top, path, scene);
  top.check_all_used();
  return scene;
}

Scene parse_scene_text(const std::string& path, const std::string& text, const std::vector<std::string>& overrides,
                       const std::map<std::string, double>* run_parameters) {
  return build_scene(path, text, parse_toml(path, text), overrides, run_parameters);
}

}  // namespace impl

std::vector<std::vector<double>> ParameterDesign::all_runs() const {
  if (!runs.empty()) return runs;
  std::vector<std::vector<double>> result;
  if (levels.empty()) return result;
  std::vector<std::size_t> index(levels.size(), 0);
  while (true) {
    std::vector<double> run;
    for (std::size_t k = 0; k < levels.size(); ++k) run.push_back(levels[k][index[k]]);
    result.push_back(run);
    int k = static_cast<int>(levels.size()) - 1;
    while (k >= 0 && ++index[k] == levels[k].size()) index[k--] = 0;
    if (k < 0) break;
  }
  return result;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  return impl::parse_scene_text(path, impl::read_text(path), overrides, nullptr);
}

Scene parse_scene(const std::string& text, const std::string& label, const std::vector<std::string>& overrides) {
  return impl::parse_scene_text(label, text, overrides, nullptr);
}

}  // namespace mpmrom
