// The hyper-reduction's precomputed sets (docs/rom.md): the grid nodes I that the samples reach over the training
// motion, and what each node gathers from: the samples' co-moving neighbours (Algorithm 1) or Gauss points of the dual
// cells around it (Algorithm 2).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>
#include <vector>

#include "fom/fom.hpp"
#include "rom/detail/decoder.hpp"
#include "rom/detail/rollout_driver.hpp"

namespace mpmrom {
namespace {

// The grid nodes within reach of a point at x: the union of its quadratic stencils over x +- margin cells, per axis
// [lo, hi] node indices.
void reach(const GridGeometry<real_t>& grid, const double* x, double margin, int lo[3], int hi[3]) {
  for (int d = 0; d < 3; ++d) {
    const double xi = (x[d] - grid.origin[d]) / grid.dx;
    lo[d] = std::max(0, int(std::floor(xi - 0.5 - margin)));
    hi[d] = std::min(grid.dims[d] - 1, int(std::floor(xi - 0.5 + margin)) + 2);
  }
}

template <class Visit>
void for_each_node(const GridGeometry<real_t>& grid, const int lo[3], const int hi[3], Visit&& visit) {
  for (int i = lo[0]; i <= hi[0]; ++i)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int k = lo[2]; k <= hi[2]; ++k) visit(grid.index(i, j, k));
}

// The motion the sets must cover: positions (configurations C, points P, 3) and each configuration's successor in
// time, next[c] (-1 at a run's end; empty: none), with margin cells of slack around every point's reach.
struct Motion {
  const GridGeometry<real_t>& grid;
  const std::vector<double>& positions;
  std::size_t P, C;
  double margin;
  const std::vector<int>& next;

  const double* position(std::size_t c, std::size_t p) const { return &positions[(c * P + p) * 3]; }
  // The nodes point p can reach from configuration c until the next one (its path is a straight line between them).
  void reach_from(std::size_t c, std::size_t p, int lo[3], int hi[3]) const {
    reach(grid, position(c, p), margin, lo, hi);
    if (next.empty() || next[c] < 0) return;
    int lo2[3], hi2[3];
    reach(grid, position(std::size_t(next[c]), p), margin, lo2, hi2);
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], lo2[d]), hi[d] = std::max(hi[d], hi2[d]);
  }
};

// I: every node a sample's stencil reaches over the training motion, in increasing order.
std::vector<int> reached_nodes(const Motion& m, const std::vector<int>& samples) {
  std::vector<char> reached(std::size_t(m.grid.num_nodes()), 0);  // dense: every point a sample visits P x C stencils
  for (const int s : samples)
    for (std::size_t c = 0; c < m.C; ++c) {
      int lo[3], hi[3];
      m.reach_from(c, std::size_t(s), lo, hi);
      for_each_node(m.grid, lo, hi, [&](int node) { reached[std::size_t(node)] = 1; });
    }
  std::vector<int> nodes;
  for (std::size_t n = 0; n < reached.size(); ++n)
    if (reached[n]) nodes.push_back(int(n));
  return nodes;
}

struct Box {
  int lo[3], hi[3];
};

bool intersect(const Box& a, const Box& b, Box& out) {
  for (int d = 0; d < 3; ++d) {
    out.lo[d] = std::max(a.lo[d], b.lo[d]);
    out.hi[d] = std::min(a.hi[d], b.hi[d]);
    if (out.lo[d] > out.hi[d]) return false;
  }
  return true;
}

// The samples' stencils at each training code, and the nodes a point's own reach shares with them. A few samples
// are tested box by box (a point's test costs the samples); many are marked per code, a bit a node (it costs the
// point's own stencil, whatever the number of samples: the 2048 candidates of the offline fits, or every point).
class SampleStencils {
 public:
  SampleStencils(const Motion& m, const std::vector<int>& samples)
      : m_(m), S_(samples.size()), few_(samples.size() <= few_samples) {
    const std::size_t C = m.C;
    if (few_)
      boxes_.resize(C * S_);
    else
      words_ = (std::size_t(m.grid.num_nodes()) + 63) / 64, marks_.assign(C * words_, 0);
    for (std::size_t c = 0; c < C; ++c)
      for (std::size_t k = 0; k < S_; ++k) {
        Box b;
        m.reach_from(c, std::size_t(samples[k]), b.lo, b.hi);
        if (few_)
          boxes_[c * S_ + k] = b;
        else
          for_each_node(m.grid, b.lo, b.hi, [&](int node) {
            marks_[c * words_ + std::size_t(node) / 64] |= std::uint64_t(1) << (node % 64);
          });
      }
  }
  // visit(node) for each node of `own` (a point's reach at code c) in some sample's stencil at c (repeats possible).
  template <class Visit>
  void shared_nodes(std::size_t c, const Box& own, Visit&& visit) const {
    if (!few_) {
      const std::uint64_t* marks = &marks_[c * words_];
      for_each_node(m_.grid, own.lo, own.hi, [&](int node) {
        if ((marks[std::size_t(node) / 64] >> (node % 64)) & 1) visit(node);
      });
      return;
    }
    Box shared;
    for (std::size_t k = 0; k < S_; ++k)
      if (intersect(own, boxes_[c * S_ + k], shared)) for_each_node(m_.grid, shared.lo, shared.hi, visit);
  }

 private:
  // Below this, S box tests cost less than visiting a point's stencil (up to 5 x 5 x 5 nodes with the margin).
  static constexpr std::size_t few_samples = 64;
  const Motion& m_;
  std::size_t S_;
  bool few_;
  std::vector<Box> boxes_;
  std::size_t words_ = 0;
  std::vector<std::uint64_t> marks_;
};

// Algorithm 1. Sources: the samples, then their co-moving neighbours N: every point that, at some training code,
// reaches a node of a sample's stencil at that same code (a point passing through where a sample was at another time
// never shares its nodes). Node n gathers from p if p reaches n while n is in a sample's stencil; at run time the
// nodes around the samples are then complete, and the other nodes of I, incomplete, are never read by G2P.
// slot: each grid node's index in I (-1: not in I).
void gather_comoving_sources(const Motion& m, const std::vector<int>& samples, const std::vector<int>& slot,
                             HyperReduction& h, std::vector<std::vector<int>>& gather) {
  std::vector<int> source_of(m.P, -1);
  for (const int k : samples) {
    source_of[k] = int(h.source_points.size());
    h.source_points.push_back(k);
  }
  const SampleStencils stencils(m, samples);
  std::vector<int> last(gather.size(), -1), reached;
  for (std::size_t p = 0; p < m.P; ++p) {
    reached.clear();
    for (std::size_t c = 0; c < m.C; ++c) {
      Box own;
      m.reach_from(c, p, own.lo, own.hi);
      stencils.shared_nodes(c, own, [&](int node) {
        const int n = slot[std::size_t(node)];
        if (last[std::size_t(n)] != int(p)) last[std::size_t(n)] = int(p), reached.push_back(n);
      });
    }
    if (reached.empty()) continue;
    if (source_of[p] < 0) {
      source_of[p] = int(h.source_points.size());
      h.source_points.push_back(int(p));
    }
    for (const int n : reached) gather[std::size_t(n)].push_back(source_of[p]);
  }
}

// Algorithm 2: the dual cells (the node-centred cells on which the B-splines are polynomial) around every node of I
// that the training motion brings material near.
std::set<int> quadrature_cells(const Motion& m, const std::vector<int>& nodes) {
  const GridGeometry<real_t>& grid = m.grid;
  std::vector<char> occupied(std::size_t(grid.num_nodes()), 0);
  for (std::size_t c = 0; c < m.C; ++c)
    for (std::size_t p = 0; p < m.P; ++p) {
      int lo[3], hi[3];
      reach(grid, m.position(c, p), m.margin, lo, hi);
      // the dual cell holding the point is the middle node of its stencil
      occupied[std::size_t(grid.index((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2))] = 1;
    }
  std::set<int> cells;
  for (const int node : nodes) {
    int idx[3];
    grid.indices(node, idx[0], idx[1], idx[2]);
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        for (int d = -1; d <= 1; ++d) {
          const int i = idx[0] + a, j = idx[1] + b, k = idx[2] + d;
          if (i < 0 || j < 0 || k < 0 || i >= grid.dims[0] || j >= grid.dims[1] || k >= grid.dims[2]) continue;
          // keep cells next to material somewhere in the training motion
          bool near = false;
          for (int e = -1; e <= 1 && !near; ++e)
            for (int f = -1; f <= 1 && !near; ++f)
              for (int g = -1; g <= 1 && !near; ++g) {
                const int ii = i + e, jj = j + f, kk = k + g;
                if (ii < 0 || jj < 0 || kk < 0 || ii >= grid.dims[0] || jj >= grid.dims[1] || kk >= grid.dims[2])
                  continue;
                near = occupied[std::size_t(grid.index(ii, jj, kk))] != 0;
              }
          if (near) cells.insert(grid.index(i, j, k));
        }
  }
  return cells;
}

// Algorithm 2: order^3 Gauss points in each of the cells, and each node gathers the points of the cells around it.
void gather_quadrature_points(const GridGeometry<real_t>& grid, const std::set<int>& cells, int order,
                              HyperReduction& h, std::vector<std::vector<int>>& gather) {
  static const double gauss_points[3][3] = {
      {0, 0, 0}, {-0.5773502691896257, 0.5773502691896257, 0}, {-0.7745966692414834, 0, 0.7745966692414834}};
  static const double gauss_weights[3][3] = {{2, 0, 0}, {1, 1, 0}, {5.0 / 9, 8.0 / 9, 5.0 / 9}};
  const double half = 0.5 * grid.dx;
  std::unordered_map<int, int> first_point;
  for (const int cell : cells) {
    int idx[3];
    grid.indices(cell, idx[0], idx[1], idx[2]);
    const Vec3<real_t> center = grid.position(idx[0], idx[1], idx[2]);
    first_point[cell] = int(h.quadrature_weight.size());
    for (int a = 0; a < order; ++a)
      for (int b = 0; b < order; ++b)
        for (int d = 0; d < order; ++d) {
          h.quadrature_x.push_back(center[0] + half * gauss_points[order - 1][a]);
          h.quadrature_x.push_back(center[1] + half * gauss_points[order - 1][b]);
          h.quadrature_x.push_back(center[2] + half * gauss_points[order - 1][d]);
          h.quadrature_weight.push_back(half * half * half * gauss_weights[order - 1][a] * gauss_weights[order - 1][b] *
                                        gauss_weights[order - 1][d]);
        }
  }
  const int per_cell = order * order * order;
  for (std::size_t n = 0; n < h.nodes.size(); ++n) {
    int idx[3];
    grid.indices(h.nodes[n], idx[0], idx[1], idx[2]);
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        for (int d = -1; d <= 1; ++d) {
          const int i = idx[0] + a, j = idx[1] + b, k = idx[2] + d;
          if (i < 0 || j < 0 || k < 0 || i >= grid.dims[0] || j >= grid.dims[1] || k >= grid.dims[2]) continue;
          const auto it = first_point.find(grid.index(i, j, k));
          if (it == first_point.end()) continue;
          for (int q = 0; q < per_cell; ++q) gather[n].push_back(it->second + q);
        }
  }
}

}  // namespace

HyperReduction impl::hyper_reduction_from_motion(const Scene& scene, const RomSettings& settings,
                                                 const std::vector<int>& samples, const std::vector<double>& positions,
                                                 std::size_t P, const std::vector<int>& next) {
  HyperReduction h;
  h.samples = samples;
  if (settings.method == RomMethod::Galerkin) return h;  // no grid: the samples are all it evaluates
  const GridGeometry<real_t> grid = grid_for_scene(scene);
  const Motion motion{grid, positions, P, positions.size() / (3 * P), settings.envelope_margin, next};
  h.nodes = reached_nodes(motion, samples);
  std::vector<int> slot(std::size_t(grid.num_nodes()), -1);  // dense: the scans below visit every point at every code
  for (std::size_t n = 0; n < h.nodes.size(); ++n) slot[std::size_t(h.nodes[n])] = int(n);
  std::vector<std::vector<int>> gather(h.nodes.size());
  if (settings.method == RomMethod::MaterialPoint)
    gather_comoving_sources(motion, samples, slot, h, gather);
  else
    gather_quadrature_points(grid, quadrature_cells(motion, h.nodes), settings.quadrature_order, h, gather);
  h.node_offsets.push_back(0);
  for (auto& list : gather) {
    std::sort(list.begin(), list.end());
    h.node_sources.insert(h.node_sources.end(), list.begin(), list.end());
    h.node_offsets.push_back(int(h.node_sources.size()));
  }
  return h;
}

HyperReduction build_hyper_reduction(const Model& model, const Scene& scene, const RomSettings& settings,
                                     const std::vector<int>& samples, const std::vector<int>& codes) {
  // The Galerkin step needs no node set, so not the training motion of every point either (codes x points x 3
  // values: 6.9 GB for the 10^6 scene's r = 8 model)
  if (settings.method == RomMethod::Galerkin)
    return impl::hyper_reduction_from_motion(scene, settings, samples, {}, 0, {});
  // The motion's configurations: the listed codes (every code when none are), each followed in time by the next code
  // of its run when that one is listed too.
  std::vector<int> listed = codes;
  if (listed.empty()) {
    listed.resize(model.num_codes());
    std::iota(listed.begin(), listed.end(), 0);
  }
  std::vector<int> in_list(model.num_codes(), -1);
  for (std::size_t k = 0; k < listed.size(); ++k) in_list.at(std::size_t(listed[k])) = int(k);
  std::map<std::int64_t, std::vector<int>> run_codes;
  for (std::size_t c = 0; c < model.num_codes(); ++c) run_codes[model.code_run[c]].push_back(int(c));
  std::vector<int> next(listed.size(), -1);
  for (auto& [run, ordered] : run_codes) {
    std::sort(ordered.begin(), ordered.end(), [&](int a, int b) { return model.code_time[a] < model.code_time[b]; });
    for (std::size_t k = 0; k + 1 < ordered.size(); ++k) {
      const int from = in_list[std::size_t(ordered[k])], to = in_list[std::size_t(ordered[k + 1])];
      if (from >= 0 && to >= 0) next[std::size_t(from)] = to;
    }
  }
  return impl::hyper_reduction_from_motion(scene, settings, samples, impl::training_positions(model, codes),
                                           model.num_points(), next);
}

}  // namespace mpmrom
