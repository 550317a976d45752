// The tests' small end-to-end scene: a 64-point block pushed by a force whose magnitude is the design parameter
// `push` (the fuzzers' seed scene, fuzz/seed_scene.toml, with other times and designs). Sweeps and trains in seconds.
#pragma once

#include <sstream>
#include <string>
#include <vector>

namespace mpmrom::test {

// pushes: the design's values of `push`; test_run: the index of the run held out as a test run.
inline std::string pushed_block_scene(const std::string& name, double end_time, int outputs, double cfl,
                                      const std::vector<double>& pushes, int test_run) {
  std::ostringstream text;
  text << "name = \"" << name << "\"\n"
       << R"([parameters]
push = 1.0
[material]
youngs_modulus = 1.0e4
poisson_ratio = 0.3
density = 1000.0
[[body]]
shape = "box"
center = [0.0, 0.0, 0.0]
size = [0.2, 0.2, 0.2]
spacing = 0.05
[grid]
lo = [-0.5, -0.5, -0.5]
hi = [0.5, 0.5, 0.5]
dx = 0.1
[[force]]
lo = [-1.0, -1.0, 0.05]
hi = [1.0, 1.0, 1.0]
magnitude = "$push"
theta_deg = 0.0
phi_deg = 0.0
[time]
)" << "end_time = " << end_time << "\noutputs = " << outputs << "\ncfl = " << cfl
       << "\n[design]\nkind = \"full_factorial\"\npush = [";
  for (std::size_t i = 0; i < pushes.size(); ++i) text << (i ? ", " : "") << pushes[i];
  text << "]\ntest = [" << test_run << "]\n";
  return text.str();
}

}  // namespace mpmrom::test
