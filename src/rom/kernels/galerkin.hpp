// The Galerkin step's per-sample terms (RomMethod::Galerkin, docs/rom.md "Galerkin step"): the reduced equations of
// motion on the manifold, d/dt (M xhatdot) = f, with the energy E(xhat) = sum_p V_p psi(F_p(xhat)) and the external
// loads, assembled by cubature over the samples without a grid:
//   f = sum_s w_s m_s q_s,   q_s = -(1 / rho0) P(F_s) : dF_s/dxhat + J_s^T (b(X_s, t) + gravity),
//   M = sum_s w_s m_s J_s^T J_s,
// with P the first Piola-Kirchhoff stress and w_s the cubature weight (1: every point). F_s is the manifold's own
// dg/dX at the sample (GalerkinStrain::Continuum; dF/dxhat_k is the kinematics' Fdot along the unit rate e_k, the
// network run r + 1 times), or MPM's (GalerkinStrain::Grid): F_s = I + sum_i u_i (x) grad_X N_i(X_s) over the 27 nodes
// of the sample's stencil in the reference configuration, each node moving as the manifold moves the material at
// Xbar_i (the node itself with APIC, the centroid of the material it carries with PIC; src/rom/detail/grid_strain.hpp),
// u_i = g(Xbar_i) - Xbar_i, 0 where the boundary holds the node, so dF/dxhat_k = sum_i dg/dxhat_k(Xbar_i) (x)
// grad_X N_i: the total-Lagrangian form of the grid's stress divergence, whose reduced force is still the gradient of
// an energy (the network run once a step at each distinct node of the samples' stencils, GridStrainNodeKinematics).
// The projection (projection.hpp) then solves M(xhat_n+1) xhatdot_n+1 = sum_s w_s m_s J_s(xhat_n+1)^T v_s + dt f,
// v_s = J_s(xhat_n) xhatdot_n: the momentum carried onto the new tangent space plus the impulse; with the grid
// transfer v_s is gathered from the stencil's nodes instead (add_transfer). Parallelism: one thread per (rollout,
// sample), and for the grid strain's nodes first one thread per (rollout, node); on GPUs, for batches that leave most
// of the GPU idle, the grid strain's sums take a team per (rollout, sample) (TeamGalerkinSampleTerms) and the
// network a team thread's lanes.
#pragma once

#include "mpm/bspline.hpp"
#include "mpm/constitutive.hpp"
#include "mpm/grid.hpp"
#include "rom/kernels/loads.hpp"
#include "rom/kernels/manifold.hpp"
#include "rom/kernels/projection.hpp"
#include "rom/kernels/sources.hpp"

namespace mpmrom::rom {

// The grid strain's nodes (GalerkinStrain::Grid): each node's displacement u = g(Xbar) - Xbar at the material point
// Xbar it moves with and its test function dg/dxhat, at Xbar or (RomSettings::galerkin_node_average) at the centroid
// of its material, both zero on the axes the boundary holds.
template <class Manifold, class MemorySpace>
struct GridStrainNodeKinematics {
  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> nodes;  // (nodes, 9): grid_strain_nodes' rows
  BatchMatrix<MemorySpace> xhat;
  BatchVectors<MemorySpace> node_u;     // out: (rollouts, nodes, 3)
  BatchJacobians<MemorySpace> node_dg;  // out: (rollouts, nodes, 3, r)
  Kokkos::View<int*, MemorySpace> flags;

  KOKKOS_INLINE_FUNCTION void operator()(const long e) const {
    const int num_nodes = int(nodes.extent(0)), r = int(xhat.extent(1));
    const int b = int(e / num_nodes), i = int(e % num_nodes);
    if (flags(b) & fatal_flags) return;
    const real_t Xbar[3] = {nodes(i, 0), nodes(i, 1), nodes(i, 2)};
    real_t g[3];
    manifold.position_and_tangent(Xbar, &xhat(b, 0), g, &node_dg(b, i, 0, 0));
    const real_t Xtest[3] = {nodes(i, 6), nodes(i, 7), nodes(i, 8)};
    if (Xtest[0] != Xbar[0] || Xtest[1] != Xbar[1] || Xtest[2] != Xbar[2]) {
      real_t unused[3];
      manifold.position_and_tangent(Xtest, &xhat(b, 0), unused, &node_dg(b, i, 0, 0));
    }
    for (int a = 0; a < 3; ++a) {
      const real_t free = nodes(i, 3 + a);
      node_u(b, i, a) = free * (g[a] - Xbar[a]);
      for (int k = 0; k < r; ++k) node_dg(b, i, a, k) *= free;
    }
  }
};

// GridStrainNodeKinematics on CPUs: a block of consecutive (rollout, node) items a thread, the network run across
// the block's lanes (Manifold::block_position_and_tangent); the items of stopped rollouts are left as they were.
template <class Manifold, class MemorySpace>
struct BlockGridStrainNodeKinematics {
  static constexpr int Lanes = nn::host_block_lanes;
  GridStrainNodeKinematics<Manifold, MemorySpace> one;  // its views

  KOKKOS_INLINE_FUNCTION void operator()(const long block) const {
    const auto& nodes = one.nodes;
    const int num_nodes = int(nodes.extent(0)), r = int(one.xhat.extent(1));
    const long n = long(one.xhat.extent(0)) * num_nodes, first = block * Lanes;
    const int count = int(n - first < Lanes ? n - first : Lanes);
    nn::PointBlock<Lanes, real_t> points;
    int b[Lanes], i[Lanes];
    bool kept[Lanes], any_test = false;
    real_t g[Lanes][3], discarded[Lanes][3 * max_latent_dim];
    real_t* dg[Lanes];
    for (int lane = 0; lane < Lanes; ++lane) {
      const long e = first + (lane < count ? lane : count - 1);
      b[lane] = int(e / num_nodes);
      i[lane] = int(e % num_nodes);
      kept[lane] = lane < count && !(one.flags(b[lane]) & fatal_flags);
      for (int d = 0; d < 3; ++d) points.X[lane][d] = nodes(i[lane], d);
      points.xhat[lane] = &one.xhat(b[lane], 0);
      dg[lane] = kept[lane] ? &one.node_dg(b[lane], i[lane], 0, 0) : discarded[lane];
    }
    one.manifold.template block_position_and_tangent<Lanes>(points, g, dg);
    for (int lane = 0; lane < Lanes; ++lane) {
      const bool test = nodes(i[lane], 6) != points.X[lane][0] || nodes(i[lane], 7) != points.X[lane][1] ||
                        nodes(i[lane], 8) != points.X[lane][2];
      any_test = any_test || (kept[lane] && test);
      for (int d = 0; d < 3; ++d) points.X[lane][d] = nodes(i[lane], 6 + d);
      if (!test) dg[lane] = discarded[lane];  // the test function at Xbar, already in place
    }
    if (any_test) {
      real_t unused[Lanes][3];
      one.manifold.template block_position_and_tangent<Lanes>(points, unused, dg);
    }
    for (int lane = 0; lane < count; ++lane) {
      if (!kept[lane]) continue;
      for (int a = 0; a < 3; ++a) {
        const real_t free = nodes(i[lane], 3 + a);
        one.node_u(b[lane], i[lane], a) = free * (g[lane][a] - nodes(i[lane], a));
        for (int k = 0; k < r; ++k) one.node_dg(b[lane], i[lane], a, k) *= free;
      }
    }
  }
};

// GridStrainNodeKinematics on teams (GPUs, where one thread per node runs the network alone): a team per
// shape.threads (rollout, node) items, one a team thread, its lanes sharing the network, as SampleKinematics.
template <class Manifold, class ExecutionSpace>
struct TeamGridStrainNodeKinematics {
  using MemorySpace = typename ExecutionSpace::memory_space;
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;

  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> nodes;  // (nodes, 9): grid_strain_nodes' rows
  BatchMatrix<MemorySpace> xhat;
  BatchVectors<MemorySpace> node_u;     // out: (rollouts, nodes, 3)
  BatchJacobians<MemorySpace> node_dg;  // out: (rollouts, nodes, 3, r)
  TeamShape shape;
  TeamScratch scratch;        // SampleKinematics::scratch_for's
  bool node_average = false;  // the test functions at the rows' centroids: a second pass of the network

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member) const {
    item(member, long(member.league_rank()) * shape.threads + member.team_rank());
  }

  // Item e of the launch on this team thread (an item past the last: the thread joins the team's barriers alone).
  KOKKOS_INLINE_FUNCTION void item(const member_type& member, const long e) const {
    const TeamPoint p = point(e);
    real_t* base = scratch.base(member, shape);  // once: both passes work in the same block
    const real_t* g =
        team_point_position_and_tangent(manifold, member, scratch, base, p.active, p.X, &xhat(p.b, 0), jacobian(p));
    write_displacement(member, p, g);
    if (node_average) {  // the whole team or none: the network's passes hold team barriers
      member.team_barrier();
      const real_t Xtest[3] = {nodes(p.i, 6), nodes(p.i, 7), nodes(p.i, 8)};
      team_point_position_and_tangent(manifold, member, scratch, base, p.active, Xtest, &xhat(p.b, 0), jacobian(p));
    }
    hold_axes(member, p);
  }

  // item's parts, for a launch that runs the network for other items too (TeamNodesAndSamples).
  KOKKOS_INLINE_FUNCTION TeamPoint point(const long e) const { return team_point(e, long(xhat.extent(0)), nodes); }
  KOKKOS_INLINE_FUNCTION real_t* jacobian(const TeamPoint& p) const {
    return p.active ? &node_dg(p.b, p.i, 0, 0) : nullptr;
  }
  KOKKOS_INLINE_FUNCTION void write_displacement(const member_type& member, const TeamPoint& p, const real_t* g) const {
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, p.active ? 3 : 0),
                         [&](const int a) { node_u(p.b, p.i, a) = nodes(p.i, 3 + a) * (g[a] - p.X[a]); });
  }
  // dg/dxhat zero on the axes the boundary holds.
  KOKKOS_INLINE_FUNCTION void hold_axes(const member_type& member, const TeamPoint& p) const {
    const int r = int(xhat.extent(1));
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, p.active ? 3 : 0), [&](const int a) {
      for (int k = 0; k < r; ++k) node_dg(p.b, p.i, a, k) *= nodes(p.i, 3 + a);
    });
  }
};

// The grid strain's nodes and the samples' positions and dg/dxhat at one latent state in one launch (GPUs, batches
// that leave most of the GPU idle: one network pass over both sets instead of two launches, each a dependent chain):
// the team items [0, rollouts * nodes) are nodes, the rest the samples' items. Both parts take the same manifold,
// shape and scratch; node_average must be off (its second pass would leave the samples' threads out of its barriers).
template <class Manifold, class ExecutionSpace>
struct TeamNodesAndSamples {
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  TeamGridStrainNodeKinematics<Manifold, ExecutionSpace> nodes;
  SampleKinematics<Manifold, ExecutionSpace> samples;

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member) const {
    const long e = long(member.league_rank()) * nodes.shape.threads + member.team_rank();
    const long node_items = long(nodes.xhat.extent(0)) * long(nodes.nodes.extent(0));
    const bool node = e < node_items;
    const TeamPoint p = node ? nodes.point(e) : samples.point(e - node_items);
    // One call of the network for both kinds of item, so that every thread meets the same team barriers: where a
    // team thread has fewer lanes than a warp, one warp holds threads of both kinds, and a barrier its threads reach
    // at different instructions is undefined (on an H200 the test of this launch, four one-lane threads a team, hung).
    const real_t* g = team_point_position_and_tangent(
        nodes.manifold, member, nodes.scratch, nodes.scratch.base(member, nodes.shape), p.active, p.X,
        node ? &nodes.xhat(p.b, 0) : &samples.xhat(p.b, 0), node ? nodes.jacobian(p) : samples.jacobian(p));
    if (node) {
      nodes.write_displacement(member, p, g);
      nodes.hold_axes(member, p);
    } else {
      samples.write_position(member, p, g);
    }
  }
};

// The latent dimensions for which the force's sums take dF/dxhat in registers (with_latent_dim); larger ones keep it
// in local memory. With every dimension up to 16 so, the kernels took 255 registers and spilled (the r = 16
// instance's 144 values of dF), and the 100-rollout poke batch's team kernel ran 2.5x slower on an H200.
inline constexpr int galerkin_register_latent_dim = 8;

template <class Manifold, class MemorySpace>
struct GalerkinSampleTerms {
  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> X;  // (samples, 3)
  BatchMatrix<MemorySpace> xhat, xhatdot;
  Kokkos::View<const RolloutLoads*, MemorySpace> loads;
  ElasticMaterial<real_t> material;
  real_t density, time;
  BatchVectors<MemorySpace> sample_x, sample_v;  // out: (rollouts, samples, 3)
  BatchJacobians<MemorySpace> sample_J;          // out: (rollouts, samples, 3, r)
  BatchMatrix<MemorySpace> sample_force;         // out: (rollouts, samples * r): q_s, per unit mass
  Kokkos::View<int*, MemorySpace> flags;

  // GalerkinStrain::Grid: each sample's 27 stencil nodes (samples, 27) into GridStrainNodeKinematics' outputs; empty:
  // the continuum strain.
  Kokkos::View<const int**, Kokkos::LayoutRight, MemorySpace> stencils;
  BatchVectors<MemorySpace> node_u;
  BatchJacobians<MemorySpace> node_dg;
  GridGeometry<real_t> grid;
  // With the grid strain: the sample's velocity gathered from its stencil's nodes as MPM's G2P gathers it, folded
  // into the force over dt (0: the manifold's velocity at the sample, no transfer).
  real_t transfer_dt = 0;
  // With the grid strain: sample_x and sample_J already hold the samples' positions and dg/dxhat (SampleKinematics on
  // teams, GPUs), else the network runs here.
  bool kinematics_given = false;
  // With the grid strain: the loads, like the stress, work against the stencil's test functions, sum_i N_i(X_s)
  // node_dg_i (RomSettings::galerkin_node_average), instead of against J_s.
  bool node_average = false;

  KOKKOS_INLINE_FUNCTION void operator()(const long e, real_t& max_speed) const {
    const int num_samples = int(X.extent(0));
    const int b = int(e / num_samples), s = int(e % num_samples);
    if (flags(b) & fatal_flags) return;
    const real_t Xs[3] = {X(s, 0), X(s, 1), X(s, 2)};
    nn::PointKinematics<real_t> kin;
    if (stencils.extent(0) > 0) {
      grid_motion(b, s, Xs, kin);
      const QuadraticStencil<real_t> stencil = sample_stencil(Xs);
      with_latent_dim<galerkin_register_latent_dim>(int(xhat.extent(1)), [&](auto R) {
        constexpr int n = decltype(R)::value;
        Mat3<real_t> F, dF[n];
        this->template grid_strain<n>(b, s, stencil, F, dF);
        this->template stress_and_force<n>(b, s, Xs, kin, F, dF, max_speed);
      });
    } else {
      manifold.kinematics(Xs, &xhat(b, 0), &xhatdot(b, 0), kin, &sample_J(b, s, 0, 0));
      Mat3<real_t> F, dF[max_latent_dim];
      continuum_strain(b, Xs, kin, F, dF);
      stress_and_force<max_latent_dim>(b, s, Xs, kin, F, dF, max_speed);
    }
  }

  KOKKOS_INLINE_FUNCTION QuadraticStencil<real_t> sample_stencil(const real_t Xs[3]) const {
    return quadratic_stencil(Vec3<real_t>{{Xs[0], Xs[1], Xs[2]}}, grid.origin, grid.inv_dx);
  }

  // With the grid strain: the sample's position, J and velocity J xhatdot; its own F is not needed.
  KOKKOS_INLINE_FUNCTION void grid_motion(int b, int s, const real_t Xs[3], nn::PointKinematics<real_t>& kin) const {
    const int r = int(xhat.extent(1));
    if (kinematics_given)
      for (int d = 0; d < 3; ++d) kin.g[d] = sample_x(b, s, d);
    else
      manifold.position_and_tangent(Xs, &xhat(b, 0), kin.g, &sample_J(b, s, 0, 0));
    for (int d = 0; d < 3; ++d) {
      kin.v[d] = 0;
      for (int k = 0; k < r; ++k) kin.v[d] += sample_J(b, s, d, k) * xhatdot(b, k);
    }
  }

  // From F and dF/dxhat at the sample: its generalised force q_s, the transfer's share, its position and velocity.
  // N: dF's length: r itself, a compile-time constant (dF in registers), or max_latent_dim, bounded by r at run time.
  template <int N>
  KOKKOS_INLINE_FUNCTION void stress_and_force(int b, int s, const real_t Xs[3], const nn::PointKinematics<real_t>& kin,
                                               const Mat3<real_t>& F, const Mat3<real_t> (&dF)[N],
                                               real_t& max_speed) const {
    const int r = int(xhat.extent(1));
    if (!(determinant(F) > real_t(0))) {
      Kokkos::atomic_or(&flags(b), int(flag_inverted));
      return;
    }
    const Mat3<real_t> P = first_piola(material, F);
    Vec3<real_t> body = loads(b).force_per_unit_mass({{Xs[0], Xs[1], Xs[2]}}, time);
    for (int d = 0; d < 3; ++d) body[d] += loads(b).gravity[d];
    const bool through_nodes = node_average && stencils.extent(0) > 0;
    const QuadraticStencil<real_t> stencil = through_nodes ? sample_stencil(Xs) : QuadraticStencil<real_t>{};
    const int n = N < max_latent_dim ? N : r;
    MPMROM_UNROLL
    for (int k = 0; k < n; ++k) {
      real_t power = 0;  // P : dF/dxhat_k
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) power += P(i, j) * dF[k](i, j);
      sample_force(b, s * r + k) = plus_load_work(b, s, k, body, through_nodes ? &stencil : nullptr, -power / density);
    }
    if (stencils.extent(0) > 0 && transfer_dt > 0) add_transfer(b, s, sample_stencil(Xs), kin);
    for (int d = 0; d < 3; ++d) {
      sample_x(b, s, d) = kin.g[d];
      sample_v(b, s, d) = kin.v[d];
    }
    const real_t speed = norm(Vec3<real_t>{{kin.v[0], kin.v[1], kin.v[2]}});
    if (speed > max_speed) max_speed = speed;
  }

  // q plus the load's generalised force along xhat_k per unit mass: body . J_s e_k, or with the node average (the
  // sample's stencil given) the stencil's interpolation of its nodes' test functions (MPM's G2P of the nodes' change,
  // averaged by the projection).
  KOKKOS_INLINE_FUNCTION real_t plus_load_work(int b, int s, int k, const Vec3<real_t>& body,
                                               const QuadraticStencil<real_t>* stencil, real_t q) const {
    real_t work = q;
    if (stencil == nullptr) {
      for (int d = 0; d < 3; ++d) work += sample_J(b, s, d, k) * body[d];
      return work;
    }
    for (int n = 0; n < 27; ++n) {
      const real_t w = stencil->weight(n / 9, (n / 3) % 3, n % 3);
      for (int d = 0; d < 3; ++d) work += w * node_dg(b, stencils(s, n), d, k) * body[d];
    }
    return work;
  }

  // The manifold's own F at the sample and dF/dxhat_k, the kinematics' Fdot along each unit rate.
  KOKKOS_INLINE_FUNCTION void continuum_strain(int b, const real_t Xs[3], const nn::PointKinematics<real_t>& kin,
                                               Mat3<real_t>& F, Mat3<real_t> (&dF)[max_latent_dim]) const {
    const int r = int(xhat.extent(1));
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) = kin.F[i][j];
    real_t unit[max_latent_dim] = {};
    for (int k = 0; k < r; ++k) {
      unit[k] = real_t(1);
      nn::PointKinematics<real_t> along;
      manifold.kinematics(Xs, &xhat(b, 0), unit, along, nullptr);
      unit[k] = real_t(0);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) dF[k](i, j) = along.Fdot[i][j];
    }
  }

  // MPM's F at the sample from its stencil's node displacements, and its derivative along each latent coordinate
  // (N as stress_and_force's).
  template <int N>
  KOKKOS_INLINE_FUNCTION void grid_strain(int b, int s, const QuadraticStencil<real_t>& stencil, Mat3<real_t>& F,
                                          Mat3<real_t> (&dF)[N]) const {
    const int r = N < max_latent_dim ? N : int(xhat.extent(1));
    F = Mat3<real_t>::identity();
    MPMROM_UNROLL
    for (int k = 0; k < r; ++k) dF[k] = Mat3<real_t>::zero();
    for (int n = 0; n < 27; ++n) {
      const Vec3<real_t> grad = stencil.gradient(n / 9, (n / 3) % 3, n % 3);
      const int i = stencils(s, n);
      MPMROM_UNROLL
      for (int a = 0; a < 3; ++a) {
        MPMROM_UNROLL
        for (int c = 0; c < 3; ++c) {
          F(a, c) += node_u(b, i, a) * grad[c];
          MPMROM_UNROLL
          for (int k = 0; k < r; ++k) dF[k](a, c) += node_dg(b, i, a, k) * grad[c];
        }
      }
    }
  }

  // One entry of grid_strain's sums, in its order, for a team thread: (a, c) of F (entry = 3 a + c) or of
  // dF/dxhat_k (entry = 9 (k + 1) + 3 a + c).
  KOKKOS_INLINE_FUNCTION real_t grid_strain_entry(int b, int s, const QuadraticStencil<real_t>& stencil,
                                                  int entry) const {
    const int k = entry / 9 - 1, a = entry % 9 / 3, c = entry % 3;
    real_t sum = k < 0 && a == c ? real_t(1) : real_t(0);
    // Unrolled: the 27 nodes' loads go out together, not one dependent pair of loads after another.
    MPMROM_UNROLL
    for (int n = 0; n < 27; ++n) {
      const int i = stencils(s, n);
      sum += (k < 0 ? node_u(b, i, a) : node_dg(b, i, a, k)) * stencil.gradient_component(n / 9, (n / 3) % 3, n % 3, c);
    }
    return sum;
  }

  // MPM's transfer of the sample's velocity: G2P from its stencil's nodes, each moving as the manifold moves the
  // material at it (dg/dxhat(Xbar_i) xhatdot, 0 on held axes), sum_i N_i(X_s) v_i replaces v_s in J_s^T v_s; the
  // difference over dt joins the force (the smoothing, and the held nodes' drag, of Algorithm 1's transfer).
  KOKKOS_INLINE_FUNCTION void add_transfer(int b, int s, const QuadraticStencil<real_t>& stencil,
                                           const nn::PointKinematics<real_t>& kin) const {
    const int r = int(xhat.extent(1));
    real_t gathered[3] = {0, 0, 0};
    for (int n = 0; n < 27; ++n) {
      const int i = stencils(s, n);
      const real_t w = stencil.weight(n / 9, (n / 3) % 3, n % 3);
      for (int a = 0; a < 3; ++a)
        for (int k = 0; k < r; ++k) gathered[a] += w * node_dg(b, i, a, k) * xhatdot(b, k);
    }
    for (int k = 0; k < r; ++k) {
      real_t change = 0;
      for (int a = 0; a < 3; ++a) change += sample_J(b, s, a, k) * (gathered[a] - kin.v[a]);
      sample_force(b, s * r + k) += change / transfer_dt;
    }
  }
};

// GalerkinSampleTerms with the grid strain on teams (GPUs, where one thread per (rollout, sample) leaves the force's
// sums to a few threads): a team per (rollout, sample), its threads summing the entries of F and dF/dxhat over the 27
// stencil nodes (each entry in the one-thread order), one thread then the stress and the force. Needs
// kinematics_given (SampleKinematics has run); team scratch: scratch_bytes().
template <class Manifold, class ExecutionSpace>
struct TeamGalerkinSampleTerms {
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  GalerkinSampleTerms<Manifold, typename ExecutionSpace::memory_space> terms;

  KOKKOS_INLINE_FUNCTION static constexpr std::size_t scratch_bytes() {
    return 9 * (max_latent_dim + 1) * sizeof(real_t);
  }

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member, real_t& max_speed) const {
    const int num_samples = int(terms.X.extent(0)), r = int(terms.xhat.extent(1));
    const int b = member.league_rank() / num_samples, s = member.league_rank() % num_samples;
    const real_t Xs[3] = {terms.X(s, 0), terms.X(s, 1), terms.X(s, 2)};
    const QuadraticStencil<real_t> stencil = terms.sample_stencil(Xs);
    real_t* entries = static_cast<real_t*>(member.team_scratch(0).get_shmem(scratch_bytes()));
    Kokkos::parallel_for(Kokkos::TeamThreadRange(member, 9 * (r + 1)),
                         [&](const int entry) { entries[entry] = terms.grid_strain_entry(b, s, stencil, entry); });
    member.team_barrier();
    Kokkos::single(Kokkos::PerTeam(member), [&]() {
      if (terms.flags(b) & fatal_flags) return;  // read once, by the thread that acts on it
      nn::PointKinematics<real_t> kin;
      terms.grid_motion(b, s, Xs, kin);
      with_latent_dim<galerkin_register_latent_dim>(r, [&](auto R) {
        constexpr int N = decltype(R)::value;
        const int n = N < max_latent_dim ? N : r;
        Mat3<real_t> F, dF[N];
        MPMROM_UNROLL
        for (int entry = 0; entry < 9 * (n + 1); ++entry)
          (entry < 9 ? F : dF[entry / 9 - 1])(entry % 9 / 3, entry % 3) = entries[entry];
        terms.template stress_and_force<N>(b, s, Xs, kin, F, dF, max_speed);
      });
    });
  }
};

}  // namespace mpmrom::rom
