// The manifold the reduced model moves on, as the ROM kernels see it: any type with
//   KOKKOS_FUNCTION int latent_dim() const;
//   KOKKOS_FUNCTION void kinematics(const real_t X[3], const real_t* xhat, const real_t* xhatdot,
//                                   nn::PointKinematics<real_t>& out, real_t* dgdxhat /* 3 x r or null */) const;
//   KOKKOS_FUNCTION void position_and_gradient(const real_t X[3], const real_t* xhat, real_t g[3],
//                                              real_t F[3][3]) const;
//   KOKKOS_FUNCTION void position_and_tangent(const real_t X[3], const real_t* xhat, real_t g[3],
//                                             real_t* dgdxhat /* 3 x r */) const;  // TeamFromSerial has one
// and the team interface of the batch kernels (team_shape.hpp):
//   int team_lanes() const;                       // vector lanes one point wants
//   std::size_t staged_bytes() const;              // what team_stage copies into scratch (0: nothing)
//   Manifold with_staging(bool) const;             // the same manifold with team_stage copying or not
//   TeamScratch team_scratch() const;             // scratch values: shared by the team, per thread
//   KOKKOS_FUNCTION const real_t* team_stage(const Member&, real_t* shared) const;  // the parameters to read
//   KOKKOS_FUNCTION void team_kinematics(const Member&, const real_t* staged, real_t* thread_scratch, bool active,
//        const real_t X[3], const real_t* xhat, const real_t* xhatdot, bool any_jacobian,
//        nn::PointKinematics<real_t>& out, real_t* dgdxhat) const;   // contract of nn::TeamMlpKinematics
//   KOKKOS_FUNCTION void team_position_and_tangent(const Member&, const real_t* staged, real_t* thread_scratch,
//        bool active, const real_t X[3], const real_t* xhat, nn::PointKinematics<real_t>& out /* g alone */,
//        real_t* dgdxhat) const;                     // the same, g and dg/dxhat alone
//   bool thread_tangent() const;                  // position_and_tangent one thread a point beats the team kernels
// and, for CPUs, position_and_tangent over a block of points (nn::PointBlock; dgdxhat one 3 x r array a lane):
//   template <int Lanes> KOKKOS_FUNCTION void block_position_and_tangent(const nn::PointBlock<Lanes, real_t>&,
//        real_t (*g)[3], real_t* const* dgdxhat) const;   // TeamFromSerial's runs position_and_tangent a lane
//   template <int Lanes> KOKKOS_FUNCTION void block_kinematics(const nn::PointBlock<Lanes, real_t>&,
//        const real_t* const* xhatdot, nn::PointKinematics<real_t>* out, real_t* const* dgdxhat /* null: none */)
//        const;                                       // TeamFromSerial's runs kinematics a lane
// MlpManifold adapts a trained network; tests plug in analytic maps, which get the team interface from
// TeamFromSerial. Parallelism contract: value types; kinematics and position_and_gradient within one thread.
#pragma once

#include <cstddef>
#include <type_traits>

#include "manifold/nn/mlp_block.hpp"
#include "manifold/nn/mlp_registers.hpp"
#include "manifold/nn/mlp_team.hpp"
#include "rom/kernels/team_shape.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::rom {

inline constexpr int max_latent_dim = 16;  // the r x r normal equations live in registers

// Calls f(std::integral_constant<int, R>()) with R = r for r in [1, Max], so that f's local arrays of the latent
// dimension have a compile-time size and, on GPUs, stay in registers; an r in (Max, max_latent_dim] calls
// f(std::integral_constant<int, max_latent_dim>()), which f then bounds by r at run time. A GPU kernel takes the
// registers of its largest instance: a Max below max_latent_dim keeps them within what its launches' occupancy needs.
template <int Max = max_latent_dim, int R = 1, class Function>
KOKKOS_INLINE_FUNCTION void with_latent_dim(const int r, const Function& f) {
  if constexpr (R > Max) {
    if (r <= max_latent_dim) f(std::integral_constant<int, max_latent_dim>());
  } else if (r == R) {
    f(std::integral_constant<int, R>());
  } else {
    with_latent_dim<Max, R + 1>(r, f);
  }
}

// The team interface of a manifold that has only the one-thread one: one lane of each team thread evaluates its point.
template <class Manifold>
struct TeamFromSerial {
  // g and dg/dxhat alone, from the kinematics at rest; a manifold with a cheaper way defines its own.
  KOKKOS_INLINE_FUNCTION void position_and_tangent(const real_t X[3], const real_t* xhat, real_t g[3],
                                                   real_t* dgdxhat) const {
    const real_t rest[max_latent_dim] = {};
    nn::PointKinematics<real_t> kin;
    static_cast<const Manifold&>(*this).kinematics(X, xhat, rest, kin, dgdxhat);
    for (int d = 0; d < 3; ++d) g[d] = kin.g[d];
  }
  template <int Lanes>
  KOKKOS_INLINE_FUNCTION void block_position_and_tangent(const nn::PointBlock<Lanes, real_t>& points, real_t (*g)[3],
                                                         real_t* const* dgdxhat) const {
    for (int lane = 0; lane < Lanes; ++lane)
      static_cast<const Manifold&>(*this).position_and_tangent(points.X[lane], points.xhat[lane], g[lane],
                                                               dgdxhat[lane]);
  }
  template <int Lanes>
  KOKKOS_INLINE_FUNCTION void block_kinematics(const nn::PointBlock<Lanes, real_t>& points,
                                               const real_t* const* xhatdot, nn::PointKinematics<real_t>* out,
                                               real_t* const* dgdxhat) const {
    for (int lane = 0; lane < Lanes; ++lane)
      static_cast<const Manifold&>(*this).kinematics(points.X[lane], points.xhat[lane], xhatdot[lane], out[lane],
                                                     dgdxhat[lane]);
  }
  int team_lanes() const { return 1; }
  bool thread_tangent() const { return false; }
  TeamScratch team_scratch() const { return TeamScratch{}; }
  std::size_t staged_bytes() const { return 0; }
  Manifold with_staging(bool) const { return static_cast<const Manifold&>(*this); }
  template <class Member>
  KOKKOS_INLINE_FUNCTION const real_t* team_stage(const Member&, real_t*) const {
    return nullptr;
  }
  template <class Member>
  KOKKOS_INLINE_FUNCTION void team_kinematics(const Member& member, const real_t*, real_t*, bool active,
                                              const real_t X[3], const real_t* xhat, const real_t* xhatdot, bool,
                                              nn::PointKinematics<real_t>& out, real_t* dgdxhat) const {
    if (active)
      Kokkos::single(Kokkos::PerThread(member),
                     [&]() { static_cast<const Manifold&>(*this).kinematics(X, xhat, xhatdot, out, dgdxhat); });
    member.team_barrier();
  }
  template <class Member>
  KOKKOS_INLINE_FUNCTION void team_position_and_tangent(const Member& member, const real_t*, real_t*, bool active,
                                                        const real_t X[3], const real_t* xhat,
                                                        nn::PointKinematics<real_t>& out, real_t* dgdxhat) const {
    if (active)
      Kokkos::single(Kokkos::PerThread(member),
                     [&]() { static_cast<const Manifold&>(*this).position_and_tangent(X, xhat, out.g, dgdxhat); });
    member.team_barrier();
  }
};

template <int MaxWidth, class MemorySpace>
struct MlpManifold {
  nn::Mlp<real_t, MemorySpace> mlp;
  nn::TeamMlp<real_t, MemorySpace> team;        // the same network arranged for the team kernels
  nn::RegisterMlp<real_t, MemorySpace> narrow;  // and padded for one thread a point (empty: too wide for it)
  bool stage = false;                           // the team kernels copy team.values into scratch first (with_staging)
  static constexpr bool host_space = Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible;

  KOKKOS_INLINE_FUNCTION int latent_dim() const { return mlp.layout.latent_dim; }

  KOKKOS_INLINE_FUNCTION void kinematics(const real_t X[3], const real_t* xhat, const real_t* xhatdot,
                                         nn::PointKinematics<real_t>& out, real_t* dgdxhat) const {
    nn::SerialMlpKinematics<MaxWidth>(mlp, X, xhat, xhatdot, out, dgdxhat);
  }

  KOKKOS_INLINE_FUNCTION void position_and_gradient(const real_t X[3], const real_t* xhat, real_t g[3],
                                                    real_t F[3][3]) const {
    real_t unused[3 * max_latent_dim];
    nn::SerialMlpForwardJacobian<MaxWidth>(mlp, X, xhat, g, F, unused);
  }

  // One forward pass and three reverse sweeps (4 matrix-vector products a layer), against kinematics' 11; a narrow
  // network's with its activations in registers.
  KOKKOS_INLINE_FUNCTION void position_and_tangent(const real_t X[3], const real_t* xhat, real_t g[3],
                                                   real_t* dgdxhat) const {
    if (thread_tangent()) {
      nn::RegisterMlpPositionAndTangent(narrow, X, xhat, g, dgdxhat);
      return;
    }
    real_t unused[3][3];
    nn::SerialMlpForwardJacobian<MaxWidth>(mlp, X, xhat, g, unused, dgdxhat);
  }

  template <int Lanes>
  KOKKOS_INLINE_FUNCTION void block_position_and_tangent(const nn::PointBlock<Lanes, real_t>& points, real_t (*g)[3],
                                                         real_t* const* dgdxhat) const {
    nn::BlockMlpForwardJacobian<Lanes, MaxWidth>(mlp, points, g, static_cast<real_t(*)[3][3]>(nullptr), dgdxhat);
  }
  template <int Lanes>
  KOKKOS_INLINE_FUNCTION void block_kinematics(const nn::PointBlock<Lanes, real_t>& points,
                                               const real_t* const* xhatdot, nn::PointKinematics<real_t>* out,
                                               real_t* const* dgdxhat) const {
    nn::BlockMlpKinematics<Lanes, MaxWidth>(mlp, points, xhatdot, out, dgdxhat);
  }

  KOKKOS_INLINE_FUNCTION bool thread_tangent() const { return narrow.quads.extent(0) > 0; }
  int team_lanes() const { return nn::lanes_for_width(mlp.layout.widest); }
  // What staging copies into each team's scratch, and the same manifold with staging on or off (team_launches.hpp
  // decides per launch).
  std::size_t staged_bytes() const { return std::size_t(team.arranged.size) * sizeof(real_t); }
  MlpManifold with_staging(bool on) const {
    MlpManifold copy = *this;
    copy.stage = on;
    return copy;
  }
  TeamScratch team_scratch() const {
    TeamScratch scratch;
    scratch.shared = stage ? team.arranged.size : 0;
    scratch.per_thread = host_space ? 0 : team.thread_scratch_values();
    return scratch;
  }

  template <class Member>
  KOKKOS_INLINE_FUNCTION const real_t* team_stage(const Member& member, real_t* shared) const {
    if (!stage) return team.values.data();
    // eight loads in flight a thread (the size is whole channel blocks), each across the team's lanes coalesced
    constexpr int in_flight = nn::kinematics_channels;
    const auto values = team.values;
    const int part = team.arranged.size / in_flight;
    Kokkos::parallel_for(Kokkos::TeamVectorRange(member, part), [&](const int i) {
      real_t loaded[in_flight];
      for (int c = 0; c < in_flight; ++c) loaded[c] = values(i + c * part);
      for (int c = 0; c < in_flight; ++c) shared[i + c * part] = loaded[c];
    });
    member.team_barrier();
    return shared;
  }

  template <class Member>
  KOKKOS_INLINE_FUNCTION void team_kinematics(const Member& member, const real_t* staged, real_t* thread_scratch,
                                              bool active, const real_t X[3], const real_t* xhat, const real_t* xhatdot,
                                              bool any_jacobian, nn::PointKinematics<real_t>& out,
                                              real_t* dgdxhat) const {
    // Host teams are one thread of one lane: the one-thread evaluation, with its buffers on the stack, is faster there
    if constexpr (host_space) {
      if (active) kinematics(X, xhat, xhatdot, out, dgdxhat);
    } else {
      nn::TeamMlpKinematics(member, team, staged, thread_scratch, active, X, xhat, xhatdot, any_jacobian, out, dgdxhat);
    }
  }

  // g and dg/dxhat alone (dgdxhat not null where active): the primal channel of team_kinematics, the same arithmetic.
  template <class Member>
  KOKKOS_INLINE_FUNCTION void team_position_and_tangent(const Member& member, const real_t* staged,
                                                        real_t* thread_scratch, bool active, const real_t X[3],
                                                        const real_t* xhat, nn::PointKinematics<real_t>& out,
                                                        real_t* dgdxhat) const {
    const real_t rest[max_latent_dim] = {};  // the rate does not reach g or dg/dxhat
    if constexpr (host_space) {
      if (active) kinematics(X, xhat, rest, out, dgdxhat);
    } else {
      nn::TeamMlpKinematics<1>(member, team, staged, thread_scratch, active, X, xhat, rest, true, out, dgdxhat);
    }
  }
};

}  // namespace mpmrom::rom
