// Reading scene files with toml++ (scene.cpp, scene_runs.cpp): a table's entries, checked, with "$parameter"
// references; --set overrides of entries; parse errors as one line. toml++ does not compile under nvcc: a source that
// includes this is host-only (src/CMakeLists.txt).
#pragma once

#include <toml++/toml.h>

#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/checked_integer.hpp"
#include "mpmrom/scene.hpp"

namespace mpmrom::impl {

// Throws std::runtime_error("scene <where>: <what>").
[[noreturn]] void fail(const std::string& where, const std::string& what);

// Reads one table's entries, remembering which keys were used so that unknown (misspelt) keys are reported.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string where, const std::map<std::string, double>& parameters)
      : table_(table), where_(std::move(where)), parameters_(parameters) {}

  bool has(const std::string& key) const { return table_.contains(key); }

  double number(const std::string& key, double fallback, bool required = false);
  double required_number(const std::string& key) { return number(key, 0, true); }

  // A count, index or seed: checked to be a whole number in [lo, hi] before it is converted (checked_integer).
  template <class Integer>
  Integer integer(const std::string& key, double fallback, double lo, double hi = INFINITY) {
    return whole<Integer>(number(key, fallback), key, lo, hi);
  }
  template <class Integer>
  Integer whole(double value, const std::string& what, double lo, double hi) const {
    return impl::checked_integer<Integer>(
        value, [&] { return "scene " + where_ + ": " + what; }, lo, hi);
  }

  Vec3d vec3(const std::string& key, Vec3d fallback, bool required = false);
  std::string string(const std::string& key, const std::string& fallback, bool required = false);
  const toml::table& table(const std::string& key, bool required = false);
  const toml::array* array(const std::string& key);

  void mark_used(const std::string& key) { used_.insert(key); }

  // Every key must have been read: an unknown key is almost always a typo that would silently change the run.
  void check_all_used() const;

  double to_number(const toml::node& node, const std::string& key) const;

 private:
  // The entry, marked as used; null if it is absent (an error if it is required).
  const toml::node* entry(const std::string& key, bool required);

  const toml::table& table_;
  std::string where_;
  const std::map<std::string, double>& parameters_;
  std::set<std::string> used_;
  static inline const toml::table empty_{};
};

ContactKind parse_contact(const std::string& s, const std::string& where);

AxisBox parse_box(TableReader& r, const std::string& where);

// Sets a dotted key (a.b.c) in the table from the text of a --set value.
void set_entry(toml::table& root, const std::string& dotted, const std::string& text);

double parse_override_number(const std::string& key, const std::string& text);

toml::table parse_toml(const std::string& path, const std::string& text);

// The text of a scene file.
std::string read_text(const std::string& path);

// The scene from the file's parsed table (scene.cpp); overrides with dotted keys change a copy of it.
Scene build_scene(const std::string& path, const std::string& text, const toml::table& parsed,
                  const std::vector<std::string>& overrides, const std::map<std::string, double>* run_parameters);

// build_scene of the text's table.
Scene parse_scene_text(const std::string& path, const std::string& text, const std::vector<std::string>& overrides,
                       const std::map<std::string, double>* run_parameters);

}  // namespace mpmrom::impl
