// The tests' scenes: scene files in tests/fixtures/, read whole or parsed with overrides (`--set` syntax).
#pragma once

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mpmrom/scene.hpp"

namespace mpmrom::test {

inline std::string fixture_path(const std::string& file) { return std::string(MPMROM_TEST_FIXTURES) + "/" + file; }

// The text of tests/fixtures/<file>.
inline std::string fixture_text(const std::string& file) {
  std::ifstream in(fixture_path(file));
  if (!in) throw std::runtime_error("test fixture " + fixture_path(file) + " cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// tests/fixtures/<file> parsed as a scene, with overrides.
inline Scene fixture_scene(const std::string& file, const std::vector<std::string>& overrides = {}) {
  return parse_scene(fixture_text(file), file, overrides);
}

// The small end-to-end scene (fixtures/pushed_block.toml) as the text of a scene file: pushes are the design's values
// of `push`, test_run the index of the run held out as a test run.
inline std::string pushed_block_scene(const std::string& name, double end_time, int outputs, double cfl,
                                      const std::vector<double>& pushes, int test_run) {
  std::ostringstream design;
  for (std::size_t i = 0; i < pushes.size(); ++i) design << (i ? ", " : "[") << pushes[i];
  design << "]";
  const auto text = [](double value) {
    std::ostringstream out;
    out << value;
    return out.str();
  };
  // the name is no table entry that an override could set
  std::string file = fixture_text("pushed_block.toml");
  const std::string default_name = "name = \"pushed_block\"";
  file.replace(file.find(default_name), default_name.size(), "name = \"" + name + "\"");
  return parse_scene(
             file, name,
             {"time.end_time=" + text(end_time), "time.outputs=" + std::to_string(outputs), "time.cfl=" + text(cfl),
              "design.push=" + design.str(), "design.test=[" + std::to_string(test_run) + "]"})
      .source_text;
}

}  // namespace mpmrom::test
