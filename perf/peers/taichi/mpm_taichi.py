#!/usr/bin/env python3
"""The peer full-order model: Taichi's MLS-MPM (the kernels of its own mpm examples) on one of our scenes.

Quadratic B-splines, APIC with the stress folded into the affine matrix (MLS-MPM, Hu et al. 2018), fixed corotated
elasticity through `ti.svd`, atomics on a dense grid; our scene's particles in our order (read from a snapshot file
of `mpmrom simulate`), its grid, material, walls, prescribed-velocity regions and forces. What differs from our FOM
is the discretisation of the stress force and of the F update (MLS: the affine matrix C for both; ours: the weight
gradients), which agree to the spatial discretisation's order (checked by `agree.py`), and what the step leaves out
(no stencil-inside check, no diagnostics, no host wait: kernels are queued and synchronised around the timed block).

Usage:
  mpm_taichi.py SCENE.toml SNAPSHOT.h5 bench --arch cpu|cuda --precision float|double --layout aos|soa
                --dt DT --steps N [--warmup W] [--threads T]           -> one JSON object on stdout
  mpm_taichi.py SCENE.toml SNAPSHOT.h5 trajectory --dt DT --out OUT.npz [...]
                                      -> positions at the snapshot's output times, each interval in equal steps <= DT
"""
import argparse
import contextlib
import json
import math
import sys
import time
import tomllib

import h5py
import numpy as np

with contextlib.redirect_stdout(sys.stderr):  # Taichi's banners; stdout holds the result only
    import taichi as ti


def fail(message):
    print(f"mpm_taichi.py: {message}", file=sys.stderr)
    sys.exit(1)


def substitute(value, parameters):
    """A scene value, with "$name" taken from the scene's [parameters] (as `mpmrom` does)."""
    if isinstance(value, str) and value.startswith("$"):
        if value[1:] not in parameters:
            fail(f"the scene's ${value[1:]} is not a parameter")
        return float(parameters[value[1:]])
    return value


def force_vector(entry, parameters):
    if "force" in entry:
        return np.array([substitute(f, parameters) for f in entry["force"]], dtype=np.float64)
    magnitude = substitute(entry["magnitude"], parameters)
    theta = math.radians(substitute(entry.get("theta_deg", 0.0), parameters))
    phi = math.radians(substitute(entry.get("phi_deg", 0.0), parameters))
    return magnitude * np.array([math.cos(phi) * math.cos(theta), math.cos(phi) * math.sin(theta), -math.sin(phi)])


def read_scene(scene_path, snapshot_path):
    """What the step needs, from the scene file and the particles of a snapshot of the same scene."""
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    parameters = scene.get("parameters", {})
    for key in ("ground", "walls"):
        if key in scene.get("boundary", {}):
            fail(f"[boundary] {key} is not modelled by the peer (only the default separating walls)")
    if scene.get("transfer", "apic").lower() != "apic":
        fail("the peer is APIC (MLS-MPM) only")
    material = scene["material"]
    if material.get("model", "fixed_corotated") != "fixed_corotated":
        fail("the peer models fixed corotated elasticity only")
    E, nu = float(material["youngs_modulus"]), float(material["poisson_ratio"])
    grid = scene["grid"]
    lo, hi, dx = np.array(grid["lo"], float), np.array(grid["hi"], float), float(grid["dx"])
    dims = [int(math.ceil((hi[d] - lo[d]) / dx - 1e-9)) + 1 for d in range(3)]  # as src/fom/fom.cpp
    with h5py.File(snapshot_path, "r") as f:
        X = f["reference/X"][:]
        mass = f["reference/mass"][:]
        volume = f["reference/volume"][:]
        times = f["time"][:]
        x_ref = f["x"][:]
    forces = []
    for entry in scene.get("force", []):
        region_lo, region_hi = np.array(entry["lo"], float), np.array(entry["hi"], float)
        inside = np.all((X >= region_lo) & (X <= region_hi), axis=1)
        if not inside.any():
            fail("a [[force]] region holds no particle")
        share = np.where(inside, mass / mass[inside].sum(), 0.0)
        forces.append((force_vector(entry, parameters), share, entry.get("start", -math.inf),
                       entry.get("end", math.inf)))
    dirichlet = [(np.array(e["lo"], float), np.array(e["hi"], float),
                  np.array([substitute(v, parameters) for v in e.get("velocity", [0, 0, 0])], float),
                  e.get("start", -math.inf), e.get("end", math.inf)) for e in scene.get("dirichlet", [])]
    return dict(mu=E / (2 * (1 + nu)), lam=E * nu / ((1 + nu) * (1 - 2 * nu)), origin=lo, dx=dx, dims=dims,
                gravity=np.array(scene.get("gravity", [0.0, 0.0, 0.0]), float), X=X, mass=mass, volume=volume,
                forces=forces, dirichlet=dirichlet, times=times, x_ref=x_ref)


def build(s, real, layout):
    """Fields and kernels of one MLS-MPM step on scene s."""
    n = s["X"].shape[0]
    dims = s["dims"]
    vec = lambda shape: ti.Vector.field(3, real, shape=shape, layout=layout)
    mat = lambda shape: ti.Matrix.field(3, 3, real, shape=shape, layout=layout)
    x, v, C, F, impulse = vec(n), vec(n), mat(n), mat(n), vec(n)
    m_p, vol_p = ti.field(real, n), ti.field(real, n)
    grid_v, grid_m = vec(tuple(dims)), ti.field(real, tuple(dims))
    num_regions = max(1, len(s["dirichlet"]))
    region_lo, region_hi, region_v = vec(num_regions), vec(num_regions), vec(num_regions)
    region_on = ti.field(ti.i32, num_regions)
    np_real = np.float64 if real == ti.f64 else np.float32
    x.from_numpy(s["X"].astype(np_real))
    m_p.from_numpy(s["mass"].astype(np_real))
    vol_p.from_numpy(s["volume"].astype(np_real))
    F.from_numpy(np.tile(np.eye(3, dtype=np_real), (n, 1, 1)))
    for r, (lo, hi, velocity, _, _) in enumerate(s["dirichlet"]):
        region_lo[r], region_hi[r], region_v[r] = lo.tolist(), hi.tolist(), velocity.tolist()
    mu, lam, dx = s["mu"], s["lam"], s["dx"]
    inv_dx = 1.0 / dx
    origin = ti.Vector(s["origin"].tolist(), dt=real)
    gravity = ti.Vector(s["gravity"].tolist(), dt=real)
    nd = ti.Vector(dims)

    @ti.kernel
    def clear_grid():
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.Vector.zero(real, 3)
            grid_m[I] = 0

    @ti.kernel
    def p2g(dt: real):
        for p in x:
            xp = (x[p] - origin) * inv_dx
            base = ti.cast(ti.floor(xp - 0.5), ti.i32)
            fx = xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            U, sig, V = ti.svd(F[p])
            J = F[p].determinant()
            tau = 2 * mu * (F[p] - U @ V.transpose()) @ F[p].transpose() + ti.Matrix.identity(real, 3) * lam * J * (J - 1)
            affine = (-dt * vol_p[p] * 4 * inv_dx * inv_dx) * tau + m_p[p] * C[p]
            momentum = m_p[p] * v[p] + dt * impulse[p]
            for offset in ti.static(ti.grouped(ti.ndrange(3, 3, 3))):
                dpos = (offset - fx) * dx
                weight = w[offset[0]][0] * w[offset[1]][1] * w[offset[2]][2]
                grid_v[base + offset] += weight * (momentum + affine @ dpos)
                grid_m[base + offset] += weight * m_p[p]

    @ti.kernel
    def grid_update(dt: real, regions: ti.i32):
        for I in ti.grouped(grid_m):
            if grid_m[I] > 0:
                vi = grid_v[I] / grid_m[I] + dt * gravity
                for d in ti.static(range(3)):  # separating walls on the two node layers of each face
                    if I[d] < 2 and vi[d] < 0:
                        vi[d] = 0
                    if I[d] > nd[d] - 3 and vi[d] > 0:
                        vi[d] = 0
                position = origin + I * dx
                for r in range(regions):
                    if region_on[r] and all(position >= region_lo[r]) and all(position <= region_hi[r]):
                        vi = region_v[r]
                grid_v[I] = vi

    @ti.kernel
    def g2p(dt: real):
        for p in x:
            xp = (x[p] - origin) * inv_dx
            base = ti.cast(ti.floor(xp - 0.5), ti.i32)
            fx = xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(real, 3)
            new_C = ti.Matrix.zero(real, 3, 3)
            for offset in ti.static(ti.grouped(ti.ndrange(3, 3, 3))):
                dpos = (offset - fx) * dx
                weight = w[offset[0]][0] * w[offset[1]][1] * w[offset[2]][2]
                g_v = grid_v[base + offset]
                new_v += weight * g_v
                new_C += 4 * inv_dx * inv_dx * weight * g_v.outer_product(dpos)
            v[p], C[p] = new_v, new_C
            F[p] = (ti.Matrix.identity(real, 3) + dt * new_C) @ F[p]
            x[p] += dt * new_v

    active = {}

    def set_loads(t):
        """The forces and prescribed regions active at time t (constant over a step, as in our FOM)."""
        key = tuple(start <= t < end for _, _, start, end in s["forces"] + [d[1:] for d in s["dirichlet"]])
        if active.get("key") == key:
            return
        active["key"] = key
        total = np.zeros((n, 3))
        for vector, share, start, end in s["forces"]:
            if start <= t < end:
                total += share[:, None] * vector[None, :]
        impulse.from_numpy(total.astype(np_real))
        for r, (_, _, _, start, end) in enumerate(s["dirichlet"]):
            region_on[r] = int(start <= t < end)

    def step(dt):
        clear_grid()
        p2g(dt)
        grid_update(dt, len(s["dirichlet"]))
        g2p(dt)

    return dict(step=step, set_loads=set_loads, x=x, n=n)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene")
    parser.add_argument("snapshot")
    parser.add_argument("mode", choices=["bench", "trajectory"])
    parser.add_argument("--arch", choices=["cpu", "cuda"], default="cpu")
    parser.add_argument("--precision", choices=["float", "double"], default="float")
    parser.add_argument("--layout", choices=["aos", "soa"], default="aos")
    parser.add_argument("--dt", type=float, required=True)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--threads", type=int, default=0, help="CPU threads (0: Taichi's default)")
    parser.add_argument("--out")
    args = parser.parse_args()
    if not args.dt > 0:
        fail("--dt must be positive")
    real = ti.f64 if args.precision == "double" else ti.f32
    init = dict(arch=ti.cuda if args.arch == "cuda" else ti.cpu, default_fp=real, log_level=ti.WARN)
    if args.threads > 0:
        init["cpu_max_num_threads"] = args.threads
    with contextlib.redirect_stdout(sys.stderr):
        ti.init(**init)
    s = read_scene(args.scene, args.snapshot)
    sim = build(s, real, ti.Layout.SOA if args.layout == "soa" else ti.Layout.AOS)
    if args.mode == "trajectory":
        if not args.out:
            fail("trajectory needs --out")
        times, frames, t = s["times"], [sim["x"].to_numpy()], 0.0
        for k in range(1, len(times)):
            steps = max(1, math.ceil((times[k] - times[k - 1]) / args.dt - 1e-9))
            dt = (times[k] - times[k - 1]) / steps
            for _ in range(steps):
                sim["set_loads"](t)
                sim["step"](dt)
                t += dt
            t = times[k]
            frames.append(sim["x"].to_numpy())
        np.savez(args.out, time=times, x=np.array(frames), x_ours=s["x_ref"], X=s["X"], mass=s["mass"])
        return
    sim["set_loads"](0.0)  # the loads of the run's start, as `mpmrom bench fom` steps from t = 0
    for _ in range(args.warmup):
        sim["step"](args.dt)
    ti.sync()
    start = time.perf_counter()
    for _ in range(args.steps):
        sim["step"](args.dt)
    ti.sync()
    seconds = time.perf_counter() - start
    if not np.all(np.isfinite(sim["x"].to_numpy())):
        fail("the peer's run blew up (non-finite positions)")
    print(json.dumps(dict(peer="taichi", taichi_version=".".join(map(str, ti.__version__)), arch=args.arch,
                          precision=args.precision, layout=args.layout, particles=sim["n"], steps=args.steps,
                          dt_s=args.dt, step_seconds=seconds / args.steps,
                          particle_steps_per_s=sim["n"] * args.steps / seconds)))


if __name__ == "__main__":
    main()
