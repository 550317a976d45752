#!/usr/bin/env python3
"""Packs everything the PyTorch peer (rom_step_torch.py) needs to re-run an mpmrom ROM batch into one .npz.

Usage: export_rom_inputs.py MODEL.h5 ROM.h5 SCENE.toml OUT.npz

MODEL.h5 is the trained network (docs/model_format.md), ROM.h5 an `mpmrom rollout` output of that model on SCENE.toml
(docs/rom.md: its /hyper_reduction sets, initial latent states, parameters and settings). The peer machine needs only
numpy and torch, so every HDF5 and TOML read happens here. The scene is resolved per rollout with that rollout's
parameter values, exactly as mpmrom's scene parser does it (src/scene/scene.cpp); the ROM file's latent trajectories are
stored too, as the reference for `rom_step_torch.py --validate`.
"""
import argparse
import json
import math
import sys
import tomllib

import h5py
import numpy as np

CONTACT = {"sticky": 0, "slip": 1, "separate": 2}  # src/mpm/grid_update.hpp Contact
ELASTIC = {"neo_hookean": 0, "fixed_corotated": 1}  # src/mpm/constitutive.hpp ElasticModel


def number(value, parameters):
    """A scene number, or a "$name" reference to a parameter (src/scene/scene.cpp TableReader::to_number)."""
    if isinstance(value, str) and value.startswith("$"):
        return float(parameters[value[1:]])
    return float(value)


def vec3(table, key, parameters, default=(0.0, 0.0, 0.0)):
    return [number(v, parameters) for v in table.get(key, default)]


def resolved_loads(scene, parameters, X, mass):
    """One rollout's loads as src/rom/rom.cpp loads_for_scene builds them: each force as force per unit of the mass the
    model's points hold in its region (float64 throughout, as mpmrom's double build)."""
    forces = []
    for f in scene.get("force", []):
        lo, hi = vec3(f, "lo", parameters), vec3(f, "hi", parameters)
        if "force" in f:
            force = vec3(f, "force", parameters)
        else:
            # spherical: theta the azimuth from +x, phi the angle below the horizontal (degrees)
            magnitude = number(f["magnitude"], parameters)
            theta = number(f["theta_deg"], parameters) * math.pi / 180
            phi = number(f["phi_deg"], parameters) * math.pi / 180
            force = [magnitude * math.cos(phi) * math.cos(theta), magnitude * math.cos(phi) * math.sin(theta),
                     -magnitude * math.sin(phi)]
        inside = np.all((X >= lo) & (X <= hi), axis=1)
        region_mass = 0.0
        for m in mass[inside]:  # in point order, as mpmrom sums it
            region_mass += m
        if not region_mass > 0:
            sys.exit("a [[force]] region holds none of the model's material points")
        forces.append(([c / region_mass for c in force], lo + hi,
                       [number(f.get("start", 0), parameters), min(number(f.get("end", 1e300), parameters), 1e30)]))
    dirichlet = []
    for d in scene.get("dirichlet", []):
        dirichlet.append((vec3(d, "lo", parameters) + vec3(d, "hi", parameters), vec3(d, "velocity", parameters),
                          [number(d.get("start", 0), parameters), min(number(d.get("end", 1e300), parameters), 1e30)]))
    return forces, dirichlet, vec3(scene, "gravity", parameters)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("rom")
    parser.add_argument("scene")
    parser.add_argument("out")
    args = parser.parse_args()

    with h5py.File(args.model, "r") as f:
        net = f["network"].attrs
        r, width, depth = int(net["latent_dim"]), int(net["width"]), int(net["depth"])
        params = f["network/params"][...].astype(np.float64)
        standardization = {k: f["network/" + k][...] for k in ("input_mean", "input_scale", "output_mean",
                                                                "output_scale")}
        X = f["reference/X"][...].astype(np.float64)
        mass = f["reference/mass"][...].astype(np.float64)
        volume = f["reference/volume"][...].astype(np.float64)

    with h5py.File(args.rom, "r") as f:
        if "hyper_reduction" not in f:
            sys.exit(f"{args.rom} has no /hyper_reduction group: re-run `mpmrom rollout` with a build that writes it")
        settings = json.loads(f.attrs["settings"])
        scene_text = f.attrs["scene"]  # fixed-length strings come back as bytes (ROM format 3)
        scene_text = scene_text.decode() if isinstance(scene_text, bytes) else scene_text
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in f["parameters"].attrs["names"]]
        values = f["parameters/values"][...]
        samples = f["samples/indices"][...]
        hr = {k: f["hyper_reduction/" + k][...] for k in ("source_points", "nodes", "node_offsets", "node_sources")}
        xhat, xhatdot = f["latent/xhat"][...], f["latent/xhatdot"][...]
        times = f["latent/time"][...]
        steps = int(f["latent"].attrs["steps"])
        completed = f["outcome/frames_completed"][...]
        regularized = f["outcome/regularized_steps"][...]

    if settings["method"] != "point":
        sys.exit("the peer implements Algorithm 1 only (`mpmrom rollout --method point`)")
    if xhat.shape[2] != r:
        sys.exit(f"{args.rom} has latent dimension {xhat.shape[2]}, the model {r}")
    S = len(samples)
    if not np.array_equal(hr["source_points"][:S], samples):
        sys.exit("/hyper_reduction/source_points must start with the samples")
    with open(args.scene, "rb") as f:
        scene_bytes = f.read()
    if scene_bytes.decode() != scene_text:
        print(f"warning: {args.scene} differs from the scene text stored in {args.rom}; using {args.scene}",
              file=sys.stderr)
    scene = tomllib.loads(scene_bytes.decode())

    # Per rollout: [parameters] defaults overridden by the rollout's values (src/scene/scene.cpp parse). A batch shares
    # grid, material and times (mpmrom refuses one that does not); they are read with the first rollout's values.
    per_rollout = []
    for row in values:
        parameters = {k: float(v) for k, v in scene.get("parameters", {}).items()}
        parameters.update(zip(names, (float(v) for v in row)))
        per_rollout.append(parameters)
    rollouts = [resolved_loads(scene, parameters, X, mass) for parameters in per_rollout]
    B = len(rollouts)
    nf, nd = len(rollouts[0][0]), len(rollouts[0][1])

    first = per_rollout[0]
    material = scene["material"]
    E, nu = number(material["youngs_modulus"], first), number(material["poisson_ratio"], first)
    density = number(material["density"], first)
    mu = E / (2 * (1 + nu))  # src/mpm/constitutive.hpp elastic_material, same operation order
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    grid = scene["grid"]
    lo, hi, dx = np.array(vec3(grid, "lo", first)), np.array(vec3(grid, "hi", first)), number(grid["dx"], first)
    dims = np.array([math.ceil((hi[d] - lo[d]) / dx - 1e-9) + 1 for d in range(3)])  # src/fom/fom.cpp grid_for_scene
    time = scene["time"]
    ground = scene.get("ground")

    np.savez(
        args.out,
        # the network g(X; xhat) (docs/model_format.md)
        layer_dims=np.array([3 + r] + [width] * (depth - 1) + [3]), params=params, **standardization,
        # Algorithm 1's sources (samples first), nodes and gather lists (docs/rom.md, /hyper_reduction)
        num_samples=S, source_X=X[hr["source_points"]], source_mass=mass[hr["source_points"]],
        source_volume=volume[hr["source_points"]], nodes=hr["nodes"], node_offsets=hr["node_offsets"],
        node_sources=hr["node_sources"],
        # grid, material, transfer and time stepping
        grid_origin=lo, grid_dx=dx, grid_dims=dims, elastic_model=ELASTIC[material.get("model", "fixed_corotated")],
        mu=mu, lam=lam, density=density, wave_speed=math.sqrt((lam + 2 * mu) / density),
        apic=time.get("transfer", "apic") == "apic",
        cfl=settings["cfl"] if settings["cfl"] > 0 else float(time.get("cfl", 0.3)),
        projection_iterations=settings["projection_iterations"],
        walls=CONTACT[grid.get("walls", "separate")], ground=ground is not None,
        ground_height=number(ground["height"], first) if ground else 0.0,
        ground_contact=CONTACT[ground.get("contact", "separate")] if ground else CONTACT["separate"],
        # per rollout: loads and initial state
        parameter_names=np.array(names), parameter_values=values,
        force_per_mass=np.array([[f[0] for f in rl[0]] for rl in rollouts]).reshape(B, nf, 3),
        force_box=np.array([[f[1] for f in rl[0]] for rl in rollouts]).reshape(B, nf, 6),
        force_window=np.array([[f[2] for f in rl[0]] for rl in rollouts]).reshape(B, nf, 2),
        dirichlet_box=np.array([[d[0] for d in rl[1]] for rl in rollouts]).reshape(B, nd, 6),
        dirichlet_velocity=np.array([[d[1] for d in rl[1]] for rl in rollouts]).reshape(B, nd, 3),
        dirichlet_window=np.array([[d[2] for d in rl[1]] for rl in rollouts]).reshape(B, nd, 2),
        gravity=np.array([rl[2] for rl in rollouts]),
        xhat0=xhat[:, 0, :], xhatdot0=xhatdot[:, 0, :], frame_times=times,
        # mpmrom's own trajectories: the reference for --validate
        reference_xhat=xhat, reference_xhatdot=xhatdot, reference_steps=steps,
        reference_frames_completed=completed, reference_regularized_steps=regularized,
        method=settings["method"], selection=settings["selection"], scene_name=scene["name"])
    print(f"{args.out}: {B} rollout(s), r = {r}, {S} samples, {len(hr['source_points'])} sources, "
          f"{len(hr['nodes'])} nodes, {len(hr['node_sources'])} node-source pairs", file=sys.stderr)


if __name__ == "__main__":
    main()
