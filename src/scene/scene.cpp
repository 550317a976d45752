#include "mpmrom/scene.hpp"

#include "core/checked_integer.hpp"
#include "scene/sampling.hpp"

#include <toml++/toml.h>

#include <cstdio>
#include <cstdlib>

#include <cmath>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

namespace mpmrom {
namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error("scene " + where + ": " + what);
}

// Reads one table's entries, remembering which keys were used so that unknown (misspelt) keys are reported.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string where, const std::map<std::string, double>& parameters)
      : table_(table), where_(std::move(where)), parameters_(parameters) {}

  bool has(const std::string& key) const { return table_.contains(key); }

  double number(const std::string& key, double fallback, bool required = false) {
    used_.insert(key);
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) fail(where_, "missing '" + key + "'");
      return fallback;
    }
    return to_number(*node, key);
  }
  double required_number(const std::string& key) { return number(key, 0, true); }

  // A count, index or seed: checked to be a whole number in [lo, hi] before it is converted (checked_integer).
  template <class Integer>
  Integer integer(const std::string& key, double fallback, double lo, double hi = INFINITY) {
    return whole<Integer>(number(key, fallback), key, lo, hi);
  }
  template <class Integer>
  Integer whole(double value, const std::string& what, double lo, double hi) const {
    return impl::checked_integer<Integer>(value, [&] { return "scene " + where_ + ": " + what; }, lo, hi);
  }

  Vec3d vec3(const std::string& key, Vec3d fallback, bool required = false) {
    used_.insert(key);
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) fail(where_, "missing '" + key + "'");
      return fallback;
    }
    const toml::array* array = node->as_array();
    if (!array || array->size() != 3) fail(where_, "'" + key + "' must be an array of 3 numbers");
    Vec3d v{};
    for (int d = 0; d < 3; ++d) v[d] = to_number(*array->get(d), key);
    return v;
  }

  std::string string(const std::string& key, const std::string& fallback, bool required = false) {
    used_.insert(key);
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) fail(where_, "missing '" + key + "'");
      return fallback;
    }
    if (!node->is_string()) fail(where_, "'" + key + "' must be a string");
    return std::string(*node->value<std::string>());
  }

  const toml::table& table(const std::string& key, bool required = false) {
    used_.insert(key);
    const toml::node* node = table_.get(key);
    if (!node) {
      if (required) fail(where_, "missing table [" + key + "]");
      return empty_;
    }
    if (!node->is_table()) fail(where_, "'" + key + "' must be a table");
    return *node->as_table();
  }

  const toml::array* array(const std::string& key) {
    used_.insert(key);
    const toml::node* node = table_.get(key);
    if (!node) return nullptr;
    if (!node->is_array()) fail(where_, "'" + key + "' must be an array");
    return node->as_array();
  }

  void mark_used(const std::string& key) { used_.insert(key); }

  // Every key must have been read: an unknown key is almost always a typo that would silently change the run.
  void check_all_used() const {
    for (const auto& [key, node] : table_) {
      (void)node;
      if (!used_.count(std::string(key.str()))) fail(where_, "unknown key '" + std::string(key.str()) + "'");
    }
  }

  double to_number(const toml::node& node, const std::string& key) const {
    if (auto v = node.value<double>()) {
      if (!std::isfinite(*v)) fail(where_, "'" + key + "' is not finite");
      return *v;
    }
    if (auto s = node.value<std::string>()) {
      if (!s->empty() && (*s)[0] == '$') {
        const auto it = parameters_.find(s->substr(1));
        if (it == parameters_.end()) fail(where_, "'" + key + "' refers to unknown parameter '" + *s + "'");
        return it->second;
      }
    }
    fail(where_, "'" + key + "' must be a number or a \"$parameter\"");
  }

 private:
  const toml::table& table_;
  std::string where_;
  const std::map<std::string, double>& parameters_;
  std::set<std::string> used_;
  static inline const toml::table empty_{};
};

ContactKind parse_contact(const std::string& s, const std::string& where) {
  if (s == "sticky") return ContactKind::Sticky;
  if (s == "slip") return ContactKind::Slip;
  if (s == "separate") return ContactKind::Separate;
  fail(where, "contact must be sticky, slip or separate, not '" + s + "'");
}

AxisBox parse_box(TableReader& r, const std::string& where) {
  AxisBox box;
  box.lo = r.vec3("lo", {}, true);
  box.hi = r.vec3("hi", {}, true);
  for (int d = 0; d < 3; ++d)
    if (!(box.lo[d] < box.hi[d])) fail(where, "region needs lo < hi in every axis");
  return box;
}

// Sets a dotted key (a.b.c) in the table from the text of a --set value.
void set_entry(toml::table& root, const std::string& dotted, const std::string& text) {
  toml::table* table = &root;
  std::stringstream path(dotted);
  std::string part, last;
  std::vector<std::string> parts;
  while (std::getline(path, part, '.')) parts.push_back(part);
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    toml::node* next = table->get(parts[i]);
    // An array of tables is indexed by number: body.0.spacing is the first [[body]]'s spacing.
    if (next && next->is_array() && i + 2 < parts.size()) {
      toml::array& list = *next->as_array();
      char* end = nullptr;
      const long index = std::strtol(parts[i + 1].c_str(), &end, 10);
      if (parts[i + 1].empty() || *end != '\0' || index < 0 || std::size_t(index) >= list.size() ||
          !list.get(std::size_t(index))->is_table())
        throw std::runtime_error("--set " + dotted + ": '" + parts[i] + "' has no table number " + parts[i + 1]);
      table = list.get(std::size_t(index))->as_table();
      ++i;
      continue;
    }
    if (!next) {
      table->insert(parts[i], toml::table{});
      next = table->get(parts[i]);
    }
    if (!next->is_table()) throw std::runtime_error("--set " + dotted + ": '" + parts[i] + "' is not a table");
    table = next->as_table();
  }
  // a TOML value (number, array, boolean, quoted string); anything else is taken as a bare string
  char* end = nullptr;
  const double number = std::strtod(text.c_str(), &end);
  if (end && *end == '\0' && !text.empty()) {
    table->insert_or_assign(parts.back(), number);
    return;
  }
  try {
    toml::table value = toml::parse("value = " + text);
    if (value.get("value")->is_integer())
      table->insert_or_assign(parts.back(), double(*value.get("value")->value<std::int64_t>()));
    else
      table->insert_or_assign(parts.back(), std::move(*value.get("value")));
  } catch (const toml::parse_error&) {
    table->insert_or_assign(parts.back(), text);
  }
}

double parse_override_number(const std::string& key, const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || !end || *end != '\0' || !std::isfinite(value))
    throw std::runtime_error("--set " + key + ": '" + text + "' is not a finite number");
  return value;
}

toml::table parse_toml(const std::string& path, const std::string& text) {
  try {
    return toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    std::ostringstream msg;
    msg << path << ":" << e.source().begin.line << ":" << e.source().begin.column << ": " << e.description();
    throw std::runtime_error("scene " + msg.str());
  }
}

// The scene from the file's parsed table; overrides with dotted keys change a copy of it.
Scene build(const std::string& path, const std::string& text, const toml::table& parsed,
            const std::vector<std::string>& overrides, const std::map<std::string, double>* run_parameters) {
  std::optional<toml::table> changed_root;
  Scene scene;
  scene.source_text = text;
  scene.source_path = path;

  // Parameters: defaults from [parameters], then the run's values, then bare --set keys.
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
  bool entries_changed = false;
  for (const auto& o : overrides) {
    const auto eq = o.find('=');
    if (eq == std::string::npos || eq == 0) throw std::runtime_error("--set expects key=value, got '" + o + "'");
    const std::string key = o.substr(0, eq), value = o.substr(eq + 1);
    if (key.find('.') == std::string::npos) {
      if (!parameters.count(key)) throw std::runtime_error("--set " + key + ": the scene has no such parameter");
      parameters[key] = parse_override_number(key, value);
    } else {
      if (!changed_root) changed_root = parsed;
      set_entry(*changed_root, key, value);
      entries_changed = true;
    }
  }
  // Snapshots store the scene text: with entries overridden, store the table as changed so the text reproduces the run.
  if (entries_changed) {
    std::ostringstream changed;
    changed << "# " << path << " with --set " << [&] {
      std::string list;
      for (const auto& o : overrides) list += (list.empty() ? "" : " ") + o;
      return list;
    }() << "\n" << *changed_root << "\n";
    scene.source_text = changed.str();
  }
  scene.parameters = parameters;
  const toml::table& root = changed_root ? *changed_root : parsed;

  TableReader top(root, path, parameters);
  top.mark_used("parameters");
  scene.name = top.string("name", "", true);

  {
    TableReader r(top.table("material", true), path + " [material]", parameters);
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

  {
    const std::string where = path + " [grid]";
    TableReader r(top.table("grid", true), where, parameters);
    scene.domain = parse_box(r, where);
    scene.dx = r.required_number("dx");
    scene.walls = parse_contact(r.string("walls", "separate"), where);
    r.check_all_used();
    if (!(scene.dx > 0)) fail(where, "dx must be positive");
    for (int d = 0; d < 3; ++d)
      if ((scene.domain.hi[d] - scene.domain.lo[d]) / scene.dx < 4)
        fail(where, "the domain must span at least 4 cells in every axis");
  }

  {
    const std::string where = path + " [time]";
    TableReader r(top.table("time", true), where, parameters);
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

  scene.gravity = top.vec3("gravity", {0, 0, 0});

  if (top.has("ground")) {
    const std::string where = path + " [ground]";
    TableReader r(top.table("ground"), where, parameters);
    scene.ground.enabled = true;
    scene.ground.height = r.required_number("height");
    scene.ground.contact = parse_contact(r.string("contact", "separate"), where);
    r.check_all_used();
  }

  const toml::array* bodies = top.array("body");
  if (!bodies || bodies->empty()) fail(path, "needs at least one [[body]]");
  for (std::size_t i = 0; i < bodies->size(); ++i) {
    const std::string where = path + " [[body]] " + std::to_string(i + 1);
    const toml::table* t = bodies->get(i)->as_table();
    if (!t) fail(where, "must be a table");
    TableReader r(*t, where, parameters);
    BodySpec b;
    b.name = r.string("name", "body" + std::to_string(i + 1));
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
        b.points.push_back({r.to_number(*p->get(0), "points"), r.to_number(*p->get(1), "points"),
                            r.to_number(*p->get(2), "points")});
      }
    } else {
      b.count = r.integer<long>("count", 0, 0, 2e9);
      b.spacing = r.number("spacing", 0);
      b.seed = r.integer<unsigned>("seed", 1, 0);
      if ((b.count > 0) == (b.spacing > 0)) fail(where, "give exactly one of count or spacing (positive)");
      if (b.spacing < 0) fail(where, "spacing must be positive");
    }
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
    scene.bodies.push_back(b);
  }

  if (const toml::array* list = top.array("dirichlet")) {
    for (std::size_t i = 0; i < list->size(); ++i) {
      const std::string where = path + " [[dirichlet]] " + std::to_string(i + 1);
      const toml::table* t = list->get(i)->as_table();
      if (!t) fail(where, "must be a table");
      TableReader r(*t, where, parameters);
      DirichletSpec d;
      d.region = parse_box(r, where);
      d.velocity = r.vec3("velocity", {0, 0, 0});
      d.start = r.number("start", 0);
      d.end = r.number("end", 1e300);
      r.check_all_used();
      if (!(d.start < d.end)) fail(where, "start must be before end");
      scene.dirichlet.push_back(d);
    }
  }

  if (const toml::array* list = top.array("force")) {
    for (std::size_t i = 0; i < list->size(); ++i) {
      const std::string where = path + " [[force]] " + std::to_string(i + 1);
      const toml::table* t = list->get(i)->as_table();
      if (!t) fail(where, "must be a table");
      TableReader r(*t, where, parameters);
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
      scene.forces.push_back(f);
    }
  }

  if (top.has("design")) {
    const std::string where = path + " [design]";
    TableReader r(top.table("design"), where, parameters);
    const std::string kind = r.string("kind", "full_factorial");
    const toml::table& t = top.table("design");
    if (kind == "full_factorial") {
      for (const auto& [key, node] : t) {
        const std::string name(key.str());
        if (name == "kind" || name == "test") continue;
        if (!parameters.count(name)) fail(where, "'" + name + "' is not a parameter of the scene");
        const toml::array* levels = node.as_array();
        if (!levels || levels->empty()) fail(where, "'" + name + "' must be a non-empty array of levels");
        std::vector<double> values;
        for (const auto& level : *levels) values.push_back(r.to_number(level, name));
        r.mark_used(name);
        scene.design.names.push_back(name);
        scene.design.levels.push_back(values);
      }
    } else if (kind == "list") {
      const toml::array* names = r.array("names");
      const toml::array* runs = r.array("runs");
      if (!names || !runs) fail(where, "a list design needs names = [...] and runs = [[...], ...]");
      for (const auto& n : *names) {
        const auto s = n.value<std::string>();
        if (!s || !parameters.count(*s)) fail(where, "names must list parameters of the scene");
        scene.design.names.push_back(*s);
      }
      for (const auto& run : *runs) {
        const toml::array* values = run.as_array();
        if (!values || values->size() != scene.design.names.size()) fail(where, "each run needs one value per name");
        std::vector<double> row;
        for (const auto& v : *values) row.push_back(r.to_number(v, "runs"));
        scene.design.runs.push_back(row);
      }
    } else {
      fail(where, "kind must be full_factorial or list, not '" + kind + "'");
    }
    const std::size_t num_runs = scene.design.all_runs().size();
    if (const toml::array* test = r.array("test")) {
      for (const auto& v : *test) {
        const double index = r.to_number(v, "test");
        scene.design.test_runs.push_back(r.whole<int>(index, "each test run index", 0, double(num_runs) - 1));
      }
    }
    r.check_all_used();
  }
  top.check_all_used();
  return scene;
}

Scene parse(const std::string& path, const std::string& text, const std::vector<std::string>& overrides,
            const std::map<std::string, double>* run_parameters) {
  return build(path, text, parse_toml(path, text), overrides, run_parameters);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("scene " + path + ": cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

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
  return parse(path, read_text(path), overrides, nullptr);
}

Scene parse_scene(const std::string& text, const std::string& label, const std::vector<std::string>& overrides) {
  return parse(label, text, overrides, nullptr);
}

Scene refine_scene(const Scene& scene, double factor) {
  if (!(factor > 0) || !std::isfinite(factor))
    throw std::runtime_error("scene " + scene.name + ": refinement factor must be positive, not " + std::to_string(factor));
  const auto number = [](double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.17g", value);
    return std::string(text);
  };
  if (factor == 1) return override_scene(scene, {});
  // The refined grid keeps a node where the original has one at the bodies' lower faces (a fixed base stays on a
  // node) and grows outward to cover the original domain with the 2-cell margin the bodies need.
  const double dx = scene.dx / factor;
  std::vector<std::string> overrides{"grid.dx=" + number(dx)};
  Vec3d lo = scene.domain.lo, hi = scene.domain.hi, body_lo, body_hi;
  for (int d = 0; d < 3; ++d) {
    body_lo[d] = INFINITY;
    body_hi[d] = -INFINITY;
    for (const auto& b : scene.bodies) {
      body_lo[d] = std::min(body_lo[d], b.center[d] - b.half_extents[d]);
      body_hi[d] = std::max(body_hi[d], b.center[d] + b.half_extents[d]);
    }
    const double anchor =
        scene.domain.lo[d] + std::round((body_lo[d] - scene.domain.lo[d]) / scene.dx) * scene.dx;
    const double below = anchor - std::min(scene.domain.lo[d], body_lo[d] - 2 * dx);
    const double above = std::max(scene.domain.hi[d], body_hi[d] + 2 * dx) - anchor;
    lo[d] = anchor - std::ceil(below / dx - 1e-9) * dx;
    hi[d] = anchor + std::ceil(above / dx - 1e-9) * dx;
    // one more cell where round-off would put a body a hair inside the margin parse() demands
    while (body_lo[d] < lo[d] + 2 * dx) lo[d] -= dx;
    while (body_hi[d] > hi[d] - 2 * dx) hi[d] += dx;
  }
  overrides.push_back("grid.lo=[" + number(lo[0]) + "," + number(lo[1]) + "," + number(lo[2]) + "]");
  overrides.push_back("grid.hi=[" + number(hi[0]) + "," + number(hi[1]) + "," + number(hi[2]) + "]");
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const BodySpec& body = scene.bodies[i];
    if (body.sampling == SamplingKind::Explicit)
      throw std::runtime_error("scene " + scene.name + ": body '" + body.name +
                               "' is given by explicit points and cannot be refined");
    const double spacing = body.count > 0 ? lattice_spacing_for_count(body, body.count) : body.spacing;
    const std::string entry = "body." + std::to_string(i) + ".";
    overrides.push_back(entry + "spacing=" + number(spacing / factor));
    overrides.push_back(entry + "count=0");  // 0: the spacing decides
  }
  return override_scene(scene, overrides);
}

Scene override_scene(const Scene& scene, const std::vector<std::string>& overrides) {
  return parse(scene.source_path, scene.source_text, overrides, &scene.parameters);
}

struct SceneRuns::Parsed {
  std::string path, text;
  toml::table root;
};

SceneRuns::SceneRuns(const std::string& path) {
  auto parsed = std::make_shared<Parsed>();
  parsed->path = path;
  parsed->text = read_text(path);
  parsed->root = parse_toml(path, parsed->text);
  parsed_ = std::move(parsed);
}

Scene SceneRuns::run(const std::vector<std::string>& names, const std::vector<double>& values) const {
  std::map<std::string, double> parameters;
  for (std::size_t k = 0; k < names.size(); ++k) parameters[names[k]] = values.at(k);
  return build(parsed_->path, parsed_->text, parsed_->root, {}, &parameters);
}

Scene scene_for_run(const std::string& path, const std::vector<std::string>& names, const std::vector<double>& values) {
  return SceneRuns(path).run(names, values);
}

}  // namespace mpmrom
