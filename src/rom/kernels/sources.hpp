// The sources of the reduced model's particle-to-grid transfer: what each material point (Algorithm 1) or quadrature
// point (Algorithm 2) hands to the grid nodes around it, evaluated from the manifold for every rollout of a batch.
// A source is 25 numbers (source_* offsets below); its contribution to node i with weight w and gradient grad w is
//   m_i += w m,   (m v)_i += w (p + A (x_i - x)) + S grad w,
// the full-order P2G (src/mpm/p2g.hpp) with p = m v + dt m f (momentum and external impulse), A = m C (APIC, with
// C = grad_x v = Fdot F^-1 from the manifold) and S = -dt V tau / J (V the current volume, tau the Kirchhoff stress).
// Parallelism: per kernel below.
#pragma once

#include <cstddef>
#include <string>

#include "mpm/constitutive.hpp"
#include "rom/kernels/inversion.hpp"
#include "rom/kernels/loads.hpp"
#include "rom/kernels/manifold.hpp"
#include "rom/kernels/reference_domain.hpp"
#include "rom/kernels/team_shape.hpp"

namespace mpmrom::rom {

inline constexpr int source_x = 0, source_mass = 3, source_momentum = 4, source_affine = 7, source_stress = 16,
                     source_size = 25;

// (sources, source_size, rollouts), stored as make_sources says.
template <class MemorySpace>
using SourceView = Kokkos::View<real_t***, Kokkos::LayoutStride, MemorySpace>;

// On GPUs the rollouts of a batch side by side, so that threads of consecutive rollouts write and read one source's
// numbers in whole cache lines; on CPUs each source's numbers side by side, a rollout's sources together, so that a
// thread gathering a rollout's nodes one after the other finds them in its cache.
template <class MemorySpace>
SourceView<MemorySpace> make_sources(const std::string& label, int num_sources, int rollouts) {
  const std::size_t K = std::size_t(num_sources), B = std::size_t(rollouts), C = source_size;
  if (Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible)
    return SourceView<MemorySpace>(label, Kokkos::LayoutStride(K, C, C, 1, B, K * C));
  return SourceView<MemorySpace>(label, Kokkos::LayoutStride(K, C * B, C, B, B, 1));
}
template <class MemorySpace>
using BatchMatrix = Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace>;  // (rollouts, r) and similar
template <class MemorySpace>
using BatchVectors = Kokkos::View<real_t***, Kokkos::LayoutRight, MemorySpace>;  // (rollouts, points, 3)
template <class MemorySpace>
using BatchJacobians = Kokkos::View<real_t****, Kokkos::LayoutRight, MemorySpace>;  // (rollouts, points, 3, r)

// Rollout status bits, set by the kernels where a problem occurs and reported by the driver.
enum RolloutFlag : int {
  flag_inverted = 1,         // det F <= 0 at a material or quadrature point
  flag_not_finite = 2,       // a NaN or Inf in the state or the projected velocity
  flag_ill_conditioned = 4,  // the normal equations needed regularisation
  flag_left_node_set = 8,    // a sample point's stencil left the precomputed node set
  flag_singular = 16,        // the normal equations stayed singular after regularisation
  flag_ill_posed = 32,       // the normal equations were ill-conditioned and regularisation was off
  flag_energy = 64,          // the latent speed exceeded its limit (the reduced energy blew up)
  flag_inversion = 128,      // Algorithm 2: Newton's inversion failed at too many quadrature points in one step
};

// Writes one source: kinematics at a point of mass m and current volume `volume`.
template <class MemorySpace>
KOKKOS_INLINE_FUNCTION void write_source(const SourceView<MemorySpace>& sources, int b, int k,
                                         const nn::PointKinematics<real_t>& kin, real_t m, real_t volume,
                                         const Mat3<real_t>& F, const Vec3<real_t>& force_per_mass,
                                         const ElasticMaterial<real_t>& material, real_t dt, bool apic) {
  for (int d = 0; d < 3; ++d) {
    sources(k, source_x + d, b) = kin.g[d];
    sources(k, source_momentum + d, b) = m * (kin.v[d] + dt * force_per_mass[d]);
  }
  sources(k, source_mass, b) = m;
  const real_t J = determinant(F);
  Mat3<real_t> affine = Mat3<real_t>::zero();
  if (apic) {
    Mat3<real_t> Fdot;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Fdot(i, j) = kin.Fdot[i][j];
    affine = m * (Fdot * inverse(F));
  }
  const Mat3<real_t> stress = (-dt * volume / J) * kirchhoff_stress(material, F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      sources(k, source_affine + 3 * i + j, b) = affine(i, j);
      sources(k, source_stress + 3 * i + j, b) = stress(i, j);
    }
}

// F of the kinematics and its determinant J; false (and the rollout flagged inverted) when J <= 0.
template <class MemorySpace>
KOKKOS_INLINE_FUNCTION bool deformation_gradient(const nn::PointKinematics<real_t>& kin,
                                                 const Kokkos::View<int*, MemorySpace>& flags, int b, Mat3<real_t>& F,
                                                 real_t& J) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) F(i, j) = kin.F[i][j];
  J = determinant(F);
  if (J > real_t(0)) return true;
  Kokkos::atomic_or(&flags(b), int(flag_inverted));
  return false;
}

template <class MemorySpace>
KOKKOS_INLINE_FUNCTION void clear_source(const SourceView<MemorySpace>& sources, int b, int k) {
  for (int c = 0; c < source_size; ++c) sources(k, c, b) = real_t(0);
}

// Algorithm 1, step 2: the sample and neighbour material points (sample points first: k < num_samples), each with
// its full-order mass and reference volume. The samples' positions and dg/dxhat are kept for the projection.
// Parallelism: a team per shape.items() (point, rollout) items, rollouts fastest (team_shape.hpp), the samples' items
// first: on GPUs each team thread runs the network for shape.rounds items with its lanes, on CPUs the team's one
// thread runs its nn::host_block_lanes items as one block; the kinematics kept in scratch, then the team's threads
// and lanes take one item each for the stress.
template <class Manifold, class ExecutionSpace>
struct MaterialPointSources {
  using MemorySpace = typename ExecutionSpace::memory_space;
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  // On CPUs the team's items take the network as one block (the launch gives a team nn::host_block_lanes items)
  static constexpr bool host_blocks =
      Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible && math::host_lane_blocks;

  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> X;  // (points, 3)
  Kokkos::View<const real_t*, MemorySpace> mass, volume;
  BatchMatrix<MemorySpace> xhat, xhatdot;
  Kokkos::View<const RolloutLoads*, MemorySpace> loads;
  ElasticMaterial<real_t> material;
  real_t time, dt;
  bool apic;
  SourceView<MemorySpace> sources;
  BatchVectors<MemorySpace> sample_x;
  BatchJacobians<MemorySpace> sample_J;
  Kokkos::View<int*, MemorySpace> flags;
  TeamShape shape;
  TeamScratch scratch;  // the manifold's, with the items' kinematics

  static TeamScratch scratch_for(const Manifold& manifold) {
    TeamScratch scratch = manifold.team_scratch();
    scratch.per_item = kinematics_values;
    return scratch;
  }

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member) const {
    const int num_rollouts = int(xhat.extent(0)), num_samples = int(sample_x.extent(1));
    const long total = long(X.extent(0)) * num_rollouts;
    const long first = long(member.league_rank()) * shape.items();
    real_t* base = scratch.base(member, shape);
    const real_t* staged = manifold.team_stage(member, base);
    real_t* own = scratch.thread_part(base, member.team_rank());
    auto* kinematics = reinterpret_cast<nn::PointKinematics<real_t>*>(scratch.item_part(base, shape));
    if constexpr (host_blocks) {
      block_kinematics(first, kinematics);
    } else {
      team_kinematics(member, first, staged, own, kinematics);
    }
    member.team_barrier();
    Kokkos::parallel_for(Kokkos::TeamVectorRange(member, shape.items()), [&](const int item) {
      const long e = first + item;
      if (e >= total) return;
      const int k = int(e / num_rollouts), b = int(e % num_rollouts);
      const nn::PointKinematics<real_t>& kin = kinematics[item];
      Mat3<real_t> F;
      real_t J;
      if (!deformation_gradient(kin, flags, b, F, J)) {
        clear_source(sources, b, k);
        return;
      }
      const Vec3<real_t> f = loads(b).force_per_unit_mass({{X(k, 0), X(k, 1), X(k, 2)}}, time);
      write_source(sources, b, k, kin, mass(k), volume(k) * J, F, f, material, dt, apic);
      if (k < num_samples)
        for (int d = 0; d < 3; ++d) sample_x(b, k, d) = kin.g[d];
    });
  }

  // The network at the team's items on GPU teams: each team thread takes `rounds` items one after another, its lanes
  // sharing each point (the samples, the first items, also get dg/dxhat).
  KOKKOS_INLINE_FUNCTION void team_kinematics(const member_type& member, long first, const real_t* staged, real_t* own,
                                              nn::PointKinematics<real_t>* kinematics) const {
    const int num_rollouts = int(xhat.extent(0)), num_samples = int(sample_x.extent(1));
    const long total = long(X.extent(0)) * num_rollouts, sample_items = long(num_samples) * num_rollouts;
    for (int round = 0; round < shape.rounds; ++round) {
      const long round_first = first + long(round) * shape.threads;
      const int item = round * shape.threads + member.team_rank();
      const long e = first + item;
      const bool active = e < total;
      const int k = active ? int(e / num_rollouts) : 0, b = active ? int(e % num_rollouts) : 0;
      const real_t Xk[3] = {X(k, 0), X(k, 1), X(k, 2)};
      manifold.team_kinematics(member, staged, own, active, Xk, &xhat(b, 0), &xhatdot(b, 0), round_first < sample_items,
                               kinematics[item], active && k < num_samples ? &sample_J(b, k, 0, 0) : nullptr);
    }
  }

  // The network at the team's items on CPUs (a team of one thread, shape.items() = nn::host_block_lanes items): one
  // block of points across the lanes (Manifold::block_kinematics); lanes past the last item repeat it.
  KOKKOS_INLINE_FUNCTION void block_kinematics(long first, nn::PointKinematics<real_t>* kinematics) const {
    constexpr int Lanes = nn::host_block_lanes;
    const int num_rollouts = int(xhat.extent(0)), num_samples = int(sample_x.extent(1));
    const long total = long(X.extent(0)) * num_rollouts;
    const int count = int(total - first < Lanes ? total - first : Lanes);
    nn::PointBlock<Lanes, real_t> points;
    const real_t* rates[Lanes];
    real_t* J[Lanes];
    for (int lane = 0; lane < Lanes; ++lane) {
      const long e = first + (lane < count ? lane : count - 1);
      const int k = int(e / num_rollouts), b = int(e % num_rollouts);
      for (int d = 0; d < 3; ++d) points.X[lane][d] = X(k, d);
      points.xhat[lane] = &xhat(b, 0);
      rates[lane] = &xhatdot(b, 0);
      J[lane] = lane < count && k < num_samples ? &sample_J(b, k, 0, 0) : nullptr;
    }
    manifold.template block_kinematics<Lanes>(points, rates, kinematics, J);
  }
};

// Algorithm 2, step 3: quadrature points fixed in the current configuration; their reference positions are found by
// inverting g (warm-started from the previous step's). A point whose inverse lies outside the reference solid is
// outside the material and carries nothing. A failed inversion is counted; with the fallback on it is retried from
// the cold start, and if that fails too the point stands for the material point it found last step (placed where g
// puts it now); without a previous solution (or the fallback) it is dropped. Parallelism: one thread per (rollout,
// quadrature point).
template <class Manifold, class MemorySpace>
struct QuadratureSources {
  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> x;  // (quadrature points, 3)
  Kokkos::View<const real_t*, MemorySpace> weight;                   // current volume of each point
  ReferenceDomain domain;
  real_t density;
  NewtonSettings newton;
  bool fallback;
  BatchMatrix<MemorySpace> xhat, xhatdot;
  Kokkos::View<const RolloutLoads*, MemorySpace> loads;
  ElasticMaterial<real_t> material;
  real_t time, dt;
  bool apic;
  BatchVectors<MemorySpace> reference;                   // (rollouts, quadrature points, 3): warm start in, inverse out
  Kokkos::View<unsigned char**, MemorySpace> converged;  // (rollouts, quadrature points): reference holds a solution
  SourceView<MemorySpace> sources;
  Kokkos::View<int*, MemorySpace> failures;       // per rollout, all steps
  Kokkos::View<int*, MemorySpace> step_failures;  // per rollout, this step (CheckInversions resets it)
  Kokkos::View<int*, MemorySpace> fallbacks;      // per rollout, all steps: points that used last step's solution
  Kokkos::View<int*, MemorySpace> flags;

  // One fixed-point step from the identity, X = x - (g(x) - x): the cold start.
  KOKKOS_INLINE_FUNCTION Vec3<real_t> cold_start(int b, const Vec3<real_t>& xq) const {
    real_t g[3], F[3][3];
    manifold.position_and_gradient(&xq[0], &xhat(b, 0), g, F);
    return Vec3<real_t>{{xq[0] - (g[0] - xq[0]), xq[1] - (g[1] - xq[1]), xq[2] - (g[2] - xq[2])}};
  }

  KOKKOS_INLINE_FUNCTION void operator()(const long e) const {
    const int num_points = int(x.extent(0));
    const int b = int(e / num_points), q = int(e % num_points);
    const Vec3<real_t> xq{{x(q, 0), x(q, 1), x(q, 2)}};
    const Vec3<real_t> previous{{reference(b, q, 0), reference(b, q, 1), reference(b, q, 2)}};
    const bool had_solution = converged(b, q) != 0;
    Vec3<real_t> Xq = had_solution ? previous : cold_start(b, xq);
    bool ok = SerialInvertMap(manifold, xq, &xhat(b, 0), newton, Xq);
    if (!ok && fallback && had_solution) {
      Xq = cold_start(b, xq);
      ok = SerialInvertMap(manifold, xq, &xhat(b, 0), newton, Xq);
    }
    if (ok) {
      for (int d = 0; d < 3; ++d) reference(b, q, d) = Xq[d];
      converged(b, q) = 1;
    } else {
      Kokkos::atomic_add(&failures(b), 1);
      Kokkos::atomic_add(&step_failures(b), 1);
      if (fallback && had_solution) {
        Xq = previous;
        Kokkos::atomic_add(&fallbacks(b), 1);
      } else {
        converged(b, q) = 0;
        clear_source(sources, b, q);
        for (int d = 0; d < 3; ++d) sources(q, source_x + d, b) = xq[d];
        return;
      }
    }
    if (!domain.contains(Xq)) {
      clear_source(sources, b, q);
      for (int d = 0; d < 3; ++d) sources(q, source_x + d, b) = xq[d];
      return;
    }
    nn::PointKinematics<real_t> kin;
    manifold.kinematics(&Xq[0], &xhat(b, 0), &xhatdot(b, 0), kin, nullptr);
    Mat3<real_t> F;
    real_t J;
    if (!deformation_gradient(kin, flags, b, F, J)) {
      clear_source(sources, b, q);
      return;
    }
    if (ok)
      for (int d = 0; d < 3; ++d) kin.g[d] = xq[d];  // the point sits where it was placed, up to the tolerance
    const Vec3<real_t> f = loads(b).force_per_unit_mass(Xq, time);
    write_source(sources, b, q, kin, density * weight(q) / J, weight(q), F, f, material, dt, apic);
  }
};

// Algorithm 2: after the quadrature sources of a step, stops each rollout whose failed inversions exceed the limit
// and resets the step's count. Parallelism: one thread per rollout.
template <class MemorySpace>
struct CheckInversions {
  Kokkos::View<int*, MemorySpace> step_failures;
  int max_failures;
  Kokkos::View<int*, MemorySpace> flags;

  KOKKOS_INLINE_FUNCTION void operator()(const int b) const {
    if (step_failures(b) > max_failures) flags(b) |= flag_inversion;
    step_failures(b) = 0;
  }
};

// One item of a team launch as the network sees it: its rollout b, its index i there, its reference position, and
// whether it is an item at all (threads past the last take part in the team's barriers alone).
struct TeamPoint {
  bool active = false;
  int b = 0, i = 0;
  real_t X[3] = {0, 0, 0};
};

// Item e of a launch over rollouts x rows.extent(0) points whose reference positions are the first three columns of
// rows (the samples' X, the grid strain's node rows).
template <class Rows>
KOKKOS_INLINE_FUNCTION TeamPoint team_point(const long e, const long rollouts, const Rows& rows) {
  const int count = int(rows.extent(0));
  TeamPoint p;
  p.active = e >= 0 && e < rollouts * count;
  p.b = p.active ? int(e / count) : 0;
  p.i = p.active ? int(e % count) : 0;
  for (int d = 0; d < 3; ++d) p.X[d] = rows(p.i, d);
  return p;
}

// One point's position (returned) and dg/dxhat a team thread, its lanes sharing the network (SampleKinematics'
// layout: scratch from scratch_for, the position in the thread's last kinematics_values), in the team's scratch
// block base (TeamScratch::base, taken once by the kernel); the team has synchronised on return.
template <class Manifold, class Member>
KOKKOS_INLINE_FUNCTION const real_t* team_point_position_and_tangent(const Manifold& manifold, const Member& member,
                                                                     const TeamScratch& scratch, real_t* base,
                                                                     bool active, const real_t X[3], const real_t* xhat,
                                                                     real_t* dgdxhat) {
  const real_t* staged = manifold.team_stage(member, base);
  real_t* own = scratch.thread_part(base, member.team_rank());
  auto& kin = *reinterpret_cast<nn::PointKinematics<real_t>*>(own + (scratch.per_thread - kinematics_values));
  manifold.team_position_and_tangent(member, staged, own, active, X, xhat, kin, dgdxhat);
  member.team_barrier();
  return kin.g;
}

// The sample material points (fixed reference positions) for the projection: Algorithm 2's step 6, and both
// algorithms' re-projection at the trial state. Parallelism: a team per shape.threads (rollout, sample) items, one
// a team thread, its lanes sharing the network (shape.rounds is not used).
template <class Manifold, class ExecutionSpace>
struct SampleKinematics {
  using MemorySpace = typename ExecutionSpace::memory_space;
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;

  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> X;  // (samples, 3)
  BatchMatrix<MemorySpace> xhat;
  BatchVectors<MemorySpace> sample_x;
  BatchJacobians<MemorySpace> sample_J;
  TeamShape shape;
  TeamScratch scratch;  // the manifold's, with one item's PointKinematics per thread (its position used)

  static TeamScratch scratch_for(const Manifold& manifold) {
    TeamScratch scratch = manifold.team_scratch();
    scratch.per_thread = aligned_values(scratch.per_thread) + kinematics_values;
    return scratch;
  }

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member) const {
    item(member, long(member.league_rank()) * shape.threads + member.team_rank());
  }

  // Item e of the launch on this team thread (an item past the last: the thread joins the team's barriers alone).
  KOKKOS_INLINE_FUNCTION void item(const member_type& member, const long e) const {
    const TeamPoint p = point(e);
    const real_t* g = team_point_position_and_tangent(manifold, member, scratch, scratch.base(member, shape), p.active,
                                                      p.X, &xhat(p.b, 0), jacobian(p));
    write_position(member, p, g);
  }

  // item's parts, for a launch that runs the network for other items too (TeamNodesAndSamples).
  KOKKOS_INLINE_FUNCTION TeamPoint point(const long e) const { return team_point(e, long(xhat.extent(0)), X); }
  KOKKOS_INLINE_FUNCTION real_t* jacobian(const TeamPoint& p) const {
    return p.active ? &sample_J(p.b, p.i, 0, 0) : nullptr;
  }
  KOKKOS_INLINE_FUNCTION void write_position(const member_type& member, const TeamPoint& p, const real_t* g) const {
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, p.active ? 3 : 0),
                         [&](const int d) { sample_x(p.b, p.i, d) = g[d]; });
  }

  // One (rollout, sample) item a thread (a RangePolicy), for a manifold whose one-thread position_and_tangent is the
  // faster (Manifold::thread_tangent: a narrow network's, in registers); shape and scratch are not used.
  KOKKOS_INLINE_FUNCTION void operator()(const long e) const {
    const int num_samples = int(X.extent(0));
    const int b = int(e / num_samples), s = int(e % num_samples);
    const real_t Xs[3] = {X(s, 0), X(s, 1), X(s, 2)};
    real_t g[3];
    manifold.position_and_tangent(Xs, &xhat(b, 0), g, &sample_J(b, s, 0, 0));
    for (int d = 0; d < 3; ++d) sample_x(b, s, d) = g[d];
  }
};

// SampleKinematics on CPUs: a block of consecutive (rollout, sample) items a thread, the network run across the
// block's lanes (Manifold::block_position_and_tangent); the lanes past the last item repeat it.
template <class Manifold, class ExecutionSpace>
struct BlockSampleKinematics {
  static constexpr int Lanes = nn::host_block_lanes;
  SampleKinematics<Manifold, ExecutionSpace> one;  // its views

  KOKKOS_INLINE_FUNCTION void operator()(const long block) const {
    const int num_samples = int(one.X.extent(0));
    const long n = long(one.xhat.extent(0)) * num_samples, first = block * Lanes;
    const int count = int(n - first < Lanes ? n - first : Lanes);
    nn::PointBlock<Lanes, real_t> points;
    int b[Lanes], s[Lanes];
    real_t g[Lanes][3], discarded[3 * max_latent_dim];
    real_t* J[Lanes];
    for (int lane = 0; lane < Lanes; ++lane) {
      const long e = first + (lane < count ? lane : count - 1);
      b[lane] = int(e / num_samples);
      s[lane] = int(e % num_samples);
      for (int d = 0; d < 3; ++d) points.X[lane][d] = one.X(s[lane], d);
      points.xhat[lane] = &one.xhat(b[lane], 0);
      J[lane] = lane < count ? &one.sample_J(b[lane], s[lane], 0, 0) : discarded;
    }
    one.manifold.template block_position_and_tangent<Lanes>(points, g, J);
    for (int lane = 0; lane < count; ++lane)
      for (int d = 0; d < 3; ++d) one.sample_x(b[lane], s[lane], d) = g[lane][d];
  }
};

}  // namespace mpmrom::rom
