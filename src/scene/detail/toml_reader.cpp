// Reading scene files with toml++ (scene/detail/toml_reader.hpp).
#include "scene/detail/toml_reader.hpp"

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mpmrom::impl {

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error("scene " + where + ": " + what);
}

const toml::node* TableReader::entry(const std::string& key, bool required) {
  used_.insert(key);
  const toml::node* node = table_.get(key);
  if (!node && required) fail(where_, "missing '" + key + "'");
  return node;
}

double TableReader::number(const std::string& key, double fallback, bool required) {
  const toml::node* node = entry(key, required);
  if (!node) return fallback;
  return to_number(*node, key);
}

Vec3d TableReader::vec3(const std::string& key, Vec3d fallback, bool required) {
  const toml::node* node = entry(key, required);
  if (!node) return fallback;
  const toml::array* array = node->as_array();
  if (!array || array->size() != 3) fail(where_, "'" + key + "' must be an array of 3 numbers");
  Vec3d v{};
  for (int d = 0; d < 3; ++d) v[d] = to_number(*array->get(d), key);
  return v;
}

std::string TableReader::string(const std::string& key, const std::string& fallback, bool required) {
  const toml::node* node = entry(key, required);
  if (!node) return fallback;
  if (!node->is_string()) fail(where_, "'" + key + "' must be a string");
  return std::string(*node->value<std::string>());
}

const toml::table& TableReader::table(const std::string& key, bool required) {
  used_.insert(key);
  const toml::node* node = table_.get(key);
  if (!node) {
    if (required) fail(where_, "missing table [" + key + "]");
    return empty_;
  }
  if (!node->is_table()) fail(where_, "'" + key + "' must be a table");
  return *node->as_table();
}

const toml::array* TableReader::array(const std::string& key) {
  const toml::node* node = entry(key, false);
  if (!node) return nullptr;
  if (!node->is_array()) fail(where_, "'" + key + "' must be an array");
  return node->as_array();
}

void TableReader::check_all_used() const {
  for (const auto& [key, node] : table_) {
    (void)node;
    if (!used_.count(std::string(key.str()))) fail(where_, "unknown key '" + std::string(key.str()) + "'");
  }
}

double TableReader::to_number(const toml::node& node, const std::string& key) const {
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

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("scene " + path + ": cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace mpmrom::impl
