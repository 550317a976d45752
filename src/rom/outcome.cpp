// What a rollout's flags mean, in words (rom/outcome.hpp).
#include "rom/outcome.hpp"

#include <vector>

#include "rom/kernels/sources.hpp"  // the flags

namespace mpmrom {

std::string impl::describe_flags(int flags, bool with_remedies) {
  struct Cause {
    int flag;
    const char *what, *remedy;
  };
  static constexpr Cause table[] = {
      {rom::flag_inverted, "an inverted deformation gradient (det F <= 0)", "try a smaller --cfl or more --samples"},
      {rom::flag_not_finite, "a non-finite projected velocity", "try a smaller --cfl"},
      {rom::flag_left_node_set, "a sample point left the precomputed node set (motion beyond the training envelope)",
       "widen --margin, or train on runs whose motion covers these parameters"},
      {rom::flag_singular, "singular normal equations even after regularisation",
       "use more --samples or --selection greedy"},
      {rom::flag_ill_posed, "ill-conditioned normal equations (condition estimate above the limit, regularisation off)",
       "drop --no-regularize or use more --samples"},
      {rom::flag_energy, "energy blow-up: the latent speed exceeded --energy-growth times the fastest training motion",
       "try more --samples or a smaller --cfl, or raise --energy-growth if the motion is truly faster"},
      {rom::flag_inversion, "Newton's inversion failed at more than --max-failed-inversions of the quadrature points",
       "try --method point, or raise --newton-iterations"},
  };
  std::vector<std::string> causes;
  for (const Cause& c : table)
    if (flags & c.flag)
      causes.push_back(std::string(c.what) + (with_remedies ? std::string(" (") + c.remedy + ")" : ""));
  std::string out;
  for (std::size_t i = 0; i < causes.size(); ++i) out += (i ? "; " : "") + causes[i];
  return out;
}

}  // namespace mpmrom
