#!/usr/bin/env python3
"""PyTorch peer of mpmrom's reduced-order batch step: Algorithm 1 (material-point-centric) with hyper-reduction.

The same step as src/rom/detail/rom_stepper.hpp step_batch with `--method point`, written the way a PyTorch user of the
paper's network would write it: an nn.Sequential MLP, torch.func (jacfwd, jvp, jacrev, vmap) for F = dg/dX, its rate
and dg/dxhat, batched tensors over (rollouts, points), index_add_ for the particle-to-grid transfer and
torch.linalg.cholesky for the normal equations. No custom kernels. Inputs come from export_rom_inputs.py (numpy and
torch are all this script needs). perf/peers/README.md maps each stage onto mpmrom's kernels.

  rom_step_torch.py INPUTS.npz --batch 1 10 100 --steps 50 --device cuda --dtype float32 --json OUT.json
  rom_step_torch.py INPUTS.npz --device cpu --dtype float64 --validate INPUTS.npz
"""
import argparse
import itertools
import json
import math
import platform
import sys
import time

import numpy as np
import torch
from torch.func import jacfwd, jacrev, jvp, vmap

STICKY, SLIP, SEPARATE = 0, 1, 2  # src/mpm/grid_update.hpp Contact
NEO_HOOKEAN = 0                   # src/mpm/constitutive.hpp ElasticModel (else fixed corotated)
STENCIL = torch.tensor(list(itertools.product(range(3), repeat=3)))  # (27, 3): the quadratic B-spline's nodes


def deformation_map(inputs, device, dtype):
    """g(X; xhat) for one point (docs/model_format.md): X + output_mean + output_scale MLP((X - mean) / scale, xhat)."""
    dims = [int(d) for d in inputs["layer_dims"]]
    params = torch.as_tensor(inputs["params"], dtype=dtype, device=device)
    layers, offset = [], 0
    for n_in, n_out in zip(dims[:-1], dims[1:]):
        linear = torch.nn.Linear(n_in, n_out, device=device, dtype=dtype)
        linear.weight.data = params[offset:offset + n_out * n_in].reshape(n_out, n_in)  # row-major W_l, then b_l
        offset += n_out * n_in
        linear.bias.data = params[offset:offset + n_out]
        offset += n_out
        layers += [linear, torch.nn.ELU()]
    mlp = torch.nn.Sequential(*layers[:-1]).requires_grad_(False)  # weights are constants: no autograd tape
    tensor = lambda key: torch.as_tensor(inputs[key], dtype=dtype, device=device)
    input_mean, input_scale = tensor("input_mean"), tensor("input_scale")
    output_mean, output_scale = tensor("output_mean"), tensor("output_scale")

    def g(X, xhat):
        return X + output_mean + output_scale * mlp(torch.cat(((X - input_mean) / input_scale, xhat)))
    return g


class RomBatch:
    """The precomputed sets, loads and grid of a batch of rollouts, and the step that advances it."""

    def __init__(self, inputs, rows, device, dtype, polar="newton"):
        self.device, self.dtype, self.polar = device, dtype, polar
        tensor = lambda a: torch.as_tensor(np.asarray(a), dtype=dtype, device=device)
        index = lambda a: torch.as_tensor(np.asarray(a), dtype=torch.int64, device=device)
        self.g = deformation_map(inputs, device, dtype)
        self.S = int(inputs["num_samples"])
        self.X = tensor(inputs["source_X"])                    # (K, 3), samples first
        self.mass, self.volume = tensor(inputs["source_mass"]), tensor(inputs["source_volume"])
        K = self.X.shape[0]

        # Grid and the node set I; slot I is a sink for the stencil nodes a source may not feed.
        self.origin = tensor(inputs["grid_origin"])
        self.dx = float(inputs["grid_dx"])
        self.inv_dx = 1 / self.dx
        self.dims = index(inputs["grid_dims"])
        nodes = np.asarray(inputs["nodes"])
        I = self.I = len(nodes)
        slot = np.full(int(np.prod(inputs["grid_dims"])), -1)
        slot[nodes] = np.arange(I)
        self.node_slot = index(slot)
        d1, d2 = (int(d) for d in inputs["grid_dims"][1:])
        node_idx = np.stack([nodes // (d1 * d2), (nodes // d2) % d1, nodes % d2], axis=1)
        node_x = tensor(inputs["grid_origin"]) + index(node_idx).to(dtype) * self.dx
        # Node n gathers source k only if k is in n's precomputed list (co-moving neighbours, docs/rom.md), even when
        # k's stencil reaches n: the transfer must use these lists to reproduce mpmrom.
        offsets = np.asarray(inputs["node_offsets"])
        feeds = np.zeros((K, I + 1), dtype=bool)
        feeds[np.asarray(inputs["node_sources"]), np.repeat(np.arange(I), np.diff(offsets))] = True
        self.feeds = torch.as_tensor(feeds, device=device)

        # Per rollout (rows of the inputs, repeated to fill the batch): loads, boundaries, initial state.
        rows = np.asarray(rows)
        self.B = len(rows)
        X = self.X
        box = tensor(inputs["force_box"][rows])                                  # (B, nf, 6)
        inside = ((X >= box[:, :, None, :3]) & (X <= box[:, :, None, 3:])).all(-1)  # (B, nf, K)
        self.force_field = inside.to(dtype)[..., None] * tensor(inputs["force_per_mass"][rows])[:, :, None, :]
        self.force_window = tensor(inputs["force_window"][rows])
        box = tensor(inputs["dirichlet_box"][rows])
        self.dirichlet_inside = ((node_x >= box[:, :, None, :3]) & (node_x <= box[:, :, None, 3:])).all(-1)
        self.dirichlet_velocity = tensor(inputs["dirichlet_velocity"][rows])
        self.dirichlet_window = tensor(inputs["dirichlet_window"][rows])
        self.gravity = tensor(inputs["gravity"][rows])
        self.walls = int(inputs["walls"])
        node_idx = index(node_idx)
        self.wall_lower, self.wall_upper = node_idx < 2, node_idx > self.dims - 3  # (I, 3): within 2 cells of a face
        self.ground = bool(inputs["ground"])
        self.ground_below = node_x[:, 2] <= float(inputs["ground_height"])
        self.ground_contact = int(inputs["ground_contact"])
        self.xhat0, self.xhatdot0 = tensor(inputs["xhat0"][rows]), tensor(inputs["xhatdot0"][rows])

        self.mu, self.lam = float(inputs["mu"]), float(inputs["lam"])
        self.neo_hookean = int(inputs["elastic_model"]) == NEO_HOOKEAN
        self.apic = bool(inputs["apic"])
        self.iterations = int(inputs["projection_iterations"])
        self.stencil = STENCIL.to(device)

        # Kinematics of one point, batched over (rollouts, points) by two vmaps: the forward-mode tangents along X
        # give F; one jvp along xhatdot on top of them gives v = dg/dxhat xhatdot and Fdot = (dF/dxhat) xhatdot.
        def point_kinematics(X, xhat, xhatdot):
            def gradient(xhat):
                def position(X):
                    x = self.g(X, xhat)
                    return x, x
                return jacfwd(position, has_aux=True)(X)  # (F, g)
            (F, x), (Fdot, v) = jvp(gradient, (xhat,), (xhatdot,))
            return x, F, v, Fdot
        self.kinematics = vmap(vmap(point_kinematics, in_dims=(0, None, None)), in_dims=(None, 0, 0))
        self.tangent = vmap(vmap(jacrev(self.g, argnums=1), in_dims=(0, None)), in_dims=(None, 0))  # dg/dxhat

    def kirchhoff_stress(self, F, J):
        eye = torch.eye(3, dtype=self.dtype, device=self.device)
        if self.neo_hookean:  # mu F F^T + (lambda ln J - mu) I
            return self.mu * F @ F.mT + (self.lam * torch.log(J) - self.mu)[..., None, None] * eye
        # fixed corotated: 2 mu (F - R) F^T + lambda (J - 1) J I, R the rotation of F's polar decomposition
        return 2 * self.mu * (F - self.rotation(F)) @ F.mT + (self.lam * (J - 1) * J)[..., None, None] * eye

    def rotation(self, F):
        if self.polar == "svd":
            U, _, Vh = torch.linalg.svd(F)
            return U @ Vh
        # Newton's iteration R <- (R + R^-T) / 2 from R = F maps each singular value s to (s + 1/s) / 2: 8 iterations
        # reach round-off for principal stretches in [0.1, 10]. Batched torch.linalg.svd of 3 x 3 matrices is ~15x
        # slower on a GPU (83 % of the whole step on an H200).
        R = F
        for _ in range(8):
            R = 0.5 * (R + torch.linalg.inv(R).mT)
        return R

    def contact(self, v, kind, axis, sign, mask):
        """src/mpm/grid_update.hpp apply_contact on the nodes in mask."""
        if kind == STICKY:
            return torch.where(mask[..., None], 0.0, v)
        va = v[..., axis]
        blocked = mask if kind == SLIP else mask & (va * sign < 0)
        return torch.cat([v[..., :axis], torch.where(blocked, 0.0, va)[..., None], v[..., axis + 1:]], dim=-1)

    def constrained(self, v, t):
        """src/mpm/grid_update.hpp constrained_node_velocity: walls, ground, then the active Dirichlet regions."""
        for d in range(3):
            v = self.contact(v, self.walls, d, 1, self.wall_lower[:, d])
            v = self.contact(v, self.walls, d, -1, self.wall_upper[:, d])
        if self.ground:
            v = self.contact(v, self.ground_contact, 2, 1, self.ground_below)
        active = (t >= self.dirichlet_window[..., 0]) & (t < self.dirichlet_window[..., 1])  # (B, nd)
        for r in range(self.dirichlet_inside.shape[1]):
            held = active[:, r, None] & self.dirichlet_inside[:, r]
            v = torch.where(held[..., None], self.dirichlet_velocity[:, r, None, :], v)
        return v

    def project(self, J, v, xhat, dt):
        """Least squares of J xhatdot = v over the samples' rows by the normal equations; returns the next state."""
        J = J.reshape(self.B, -1, J.shape[-1])
        L = torch.linalg.cholesky(J.mT @ J)
        rate = torch.cholesky_solve(J.mT @ v.reshape(self.B, -1, 1), L)[..., 0]
        return xhat + dt * rate, rate

    def step(self, xhat, xhatdot, t, dt):
        """One step of every rollout; returns xhat, xhatdot at t + dt and the fastest sample speed (a 0-d tensor)."""
        B, S, I = self.B, self.S, self.I
        # Sources (src/rom/kernels/sources.hpp MaterialPointSources): kinematics, momentum with the external impulse,
        # APIC's m Fdot F^-1 and -dt V tau / J with V = V0 J.
        x, F, v, Fdot = self.kinematics(self.X, xhat, xhatdot)  # (B, K, 3), (B, K, 3, 3), ...
        J = torch.linalg.det(F)
        active = ((t >= self.force_window[..., 0]) & (t < self.force_window[..., 1])).to(self.dtype)  # (B, nf)
        force = torch.einsum("bf,bfkd->bkd", active, self.force_field)
        momentum = self.mass[:, None] * (v + dt * force)
        affine = self.mass[:, None, None] * torch.linalg.solve(F, Fdot, left=False) if self.apic else None
        stress = (-dt * self.volume)[:, None, None] * self.kirchhoff_stress(F, J)

        # Each source's 27 stencil nodes, weights and weight gradients (src/mpm/bspline.hpp quadratic_stencil).
        xi = (x - self.origin) * self.inv_dx
        base = torch.floor(xi - 0.5)
        f = xi - base
        w1 = torch.stack([0.5 * (1.5 - f) ** 2, 0.75 - (f - 1) ** 2, 0.5 * (f - 0.5) ** 2], dim=-1)  # (B, K, 3, 3)
        dw1 = torch.stack([-(1.5 - f), -2 * (f - 1), f - 0.5], dim=-1) * self.inv_dx
        at = lambda table, d: table[:, :, d, self.stencil[:, d]]  # (B, K, 27) along axis d
        wx, wy, wz = at(w1, 0), at(w1, 1), at(w1, 2)
        weight = wx * wy * wz
        grad = torch.stack([at(dw1, 0) * wy * wz, wx * at(dw1, 1) * wz, wx * wy * at(dw1, 2)], dim=-1)
        node = base.long()[:, :, None, :] + self.stencil  # (B, K, 27, 3) grid indices
        in_grid = ((node >= 0) & (node < self.dims)).all(-1)
        flat = (node[..., 0] * self.dims[1] + node[..., 1]) * self.dims[2] + node[..., 2]
        slot = torch.where(in_grid, self.node_slot[flat.clamp(0, len(self.node_slot) - 1)], -1)

        # P2G onto I (src/rom/kernels/transfer.hpp GatherNodeVelocities) as a scatter over the allowed (node, source)
        # pairs: the same terms as mpmrom's gather, summed in another order.
        target = torch.where(slot >= 0, slot, I)
        target = torch.where(self.feeds[torch.arange(self.X.shape[0], device=self.device)[:, None], target], target, I)
        offset = (self.origin + node.to(self.dtype) * self.dx) - x[:, :, None, :]  # node position - x
        p = momentum[:, :, None, :]
        if affine is not None:
            p = p + torch.einsum("bkrq,bknq->bknr", affine, offset)
        node_momentum = weight[..., None] * p + torch.einsum("bkrq,bknq->bknr", stress, grad)
        contributions = torch.cat([(weight * self.mass[:, None])[..., None], node_momentum], dim=-1)
        rows = (torch.arange(B, device=self.device)[:, None, None] * (I + 1) + target).reshape(-1)  # flat (B, I + 1)
        grid = torch.zeros(B * (I + 1), 4, dtype=self.dtype, device=self.device)
        grid.index_add_(0, rows, contributions.reshape(-1, 4))
        grid = grid.reshape(B, I + 1, 4)[:, :I]
        m = grid[..., 0]
        has_mass = m > 0
        node_v = grid[..., 1:] / torch.where(has_mass, m, 1)[..., None] + dt * self.gravity[:, None, :]
        node_v = torch.where(has_mass[..., None], self.constrained(node_v, t), 0.0)

        # G2P at the samples (SampleVelocities); a sample whose stencil leaves I reads zero (mpmrom also stops it).
        node_v = torch.cat([node_v, torch.zeros_like(node_v[:, :1])], dim=1)
        sample_slot = slot[:, :S]
        complete = (sample_slot >= 0).all(-1, keepdim=True)
        each = torch.arange(B, device=self.device)[:, None, None]
        gathered = node_v[each, torch.where(sample_slot >= 0, sample_slot, I)]  # (B, S, 27, 3)
        sample_v = torch.where(complete, (weight[:, :S, :, None] * gathered).sum(2), 0.0)

        # Projection (src/rom/kernels/projection.hpp), then re-projection with dg/dxhat at the trial state (docs/rom.md).
        X_samples = self.X[:S]
        xhat_next, xhatdot_next = self.project(self.tangent(X_samples, xhat), sample_v, xhat, dt)
        for _ in range(self.iterations):
            xhat_next, xhatdot_next = self.project(self.tangent(X_samples, xhat_next), sample_v, xhat, dt)
        return xhat_next, xhatdot_next, torch.linalg.vector_norm(sample_v, dim=-1).amax()


def rollout(batch, inputs):
    """The batch through the output times with mpmrom's time stepping (rom_stepper.hpp): per output interval,
    equal sub-steps no longer than cfl dx / (wave speed + fastest sample of the last step). Returns the latent
    states (B, frames, r) and the number of steps."""
    times = [float(t) for t in inputs["frame_times"]]
    cfl, dx = float(inputs["cfl"]), float(inputs["grid_dx"])
    wave_speed = float(torch.tensor(float(inputs["wave_speed"]), dtype=batch.dtype))  # real_t, as mpmrom holds it
    xhat, xhatdot = batch.xhat0, batch.xhatdot0
    frames_xhat, frames_xhatdot = [xhat], [xhatdot]
    now, max_speed, steps = 0.0, 0.0, 0
    for target in times[1:]:
        substeps = max(1, math.ceil((target - now) / (cfl * dx / (wave_speed + max_speed)) - 1e-9))
        dt = (target - now) / substeps
        for sub in range(substeps):
            xhat, xhatdot, speed = batch.step(xhat, xhatdot, now, dt)
            now = target if sub + 1 == substeps else now + dt
            steps += 1
        max_speed = float(speed)
        frames_xhat.append(xhat)
        frames_xhatdot.append(xhatdot)
    return torch.stack(frames_xhat, 1).cpu().numpy(), torch.stack(frames_xhatdot, 1).cpu().numpy(), steps


def validate(inputs, reference, device, dtype, polar):
    """Runs the exported rollouts as mpmrom did and compares the latent trajectories frame by frame, up to the first
    frame at which mpmrom had stopped a rollout (the peer has no failure detectors: past that point the batch's
    shared time step differs)."""
    if np.any(reference["reference_regularized_steps"]):
        print("note: mpmrom regularised some projections, which the peer does not", file=sys.stderr)
    batch = RomBatch(inputs, np.arange(len(inputs["xhat0"])), device, dtype, polar)
    xhat, xhatdot, steps = rollout(batch, inputs)
    frames = int(reference["reference_frames_completed"].min())
    ref_xhat, ref_xhatdot = reference["reference_xhat"][:, :frames], reference["reference_xhatdot"][:, :frames]
    xhat, xhatdot = xhat[:, :frames], xhatdot[:, :frames]
    result = {
        "rollouts": int(xhat.shape[0]), "frames_compared": frames, "frames": len(inputs["frame_times"]),
        "steps": steps, "reference_steps": int(reference["reference_steps"]),
        # max over rollouts, frames and components, relative to the largest reference value
        "xhat_max_relative_deviation": float(np.abs(xhat - ref_xhat).max() / np.abs(ref_xhat).max()),
        "xhatdot_max_relative_deviation": float(np.abs(xhatdot - ref_xhatdot).max() / np.abs(ref_xhatdot).max()),
    }
    print(f"validation: {result['rollouts']} rollout(s), {frames} of {result['frames']} frames compared, {steps} "
          f"steps (mpmrom {result['reference_steps']}); max |xhat - ref| / max |ref| = "
          f"{result['xhat_max_relative_deviation']:.3e}, xhatdot {result['xhatdot_max_relative_deviation']:.3e}",
          file=sys.stderr)
    return result


def seconds_per_step(inputs, size, steps, warmup, dt, device, dtype, polar):
    """The exported rollouts repeated to fill a batch of `size`, advanced with time step dt: warm-up steps first,
    then `steps` timed steps between two device syncs."""
    sync = torch.cuda.synchronize if device.type == "cuda" else (lambda: None)
    batch = RomBatch(inputs, np.arange(size) % len(inputs["xhat0"]), device, dtype, polar)
    xhat, xhatdot, now = batch.xhat0, batch.xhatdot0, 0.0
    for _ in range(warmup):
        xhat, xhatdot, _ = batch.step(xhat, xhatdot, now, dt)
        now += dt
    sync()
    start = time.perf_counter()
    for _ in range(steps):
        xhat, xhatdot, _ = batch.step(xhat, xhatdot, now, dt)
        now += dt
    sync()
    return (time.perf_counter() - start) / steps


def benchmark(inputs, batch_sizes, steps, warmup, device, dtype, polar):
    """Seconds per batch step for each batch size, at the time step of the first output interval."""
    times = inputs["frame_times"]
    dt_max = float(inputs["cfl"]) * float(inputs["grid_dx"]) / float(inputs["wave_speed"])
    dt = float(times[1]) / max(1, math.ceil(float(times[1]) / dt_max - 1e-9))
    points = []
    for size in batch_sizes:
        try:
            seconds = seconds_per_step(inputs, size, steps, warmup, dt, device, dtype, polar)
        except torch.cuda.OutOfMemoryError:  # a record of where the peer stops, not a failure of the run
            torch.cuda.empty_cache()
            points.append({"batch": size, "out_of_memory": True})
            print(f"batch {size}: out of memory", file=sys.stderr)
            continue
        points.append({"batch": size, "rom_step_seconds": seconds, "rom_rollout_steps_per_s": size / seconds})
        print(f"batch {size}: {seconds * 1e3:.3f} ms per batch step, {size / seconds:.4g} rollout-steps/s",
              file=sys.stderr)
    return points


def device_name(device):
    if device.type == "cuda":
        return torch.cuda.get_device_name(device)
    try:
        with open("/proc/cpuinfo") as f:
            return next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or "cpu"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", help=".npz from export_rom_inputs.py")
    parser.add_argument("--batch", type=int, nargs="+", default=[1, 10, 100, 1000], help="batch sizes to time")
    parser.add_argument("--steps", type=int, default=50, help="timed steps per batch size")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps first")
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--dtype", choices=["float32", "float64"], default="float32")
    parser.add_argument("--polar", choices=["newton", "svd"], default="newton",
                        help="fixed-corotated stress: polar rotation by Newton's iteration or torch.linalg.svd")
    parser.add_argument("--validate", metavar="REFERENCE.npz",
                        help="re-run the exported rollouts and compare with mpmrom's latent trajectories (an .npz "
                             "from export_rom_inputs.py; the inputs file itself holds them); no timing")
    parser.add_argument("--json", metavar="OUT.json", help="write the record here (else to stdout)")
    args = parser.parse_args()

    device, dtype = torch.device(args.device), getattr(torch, args.dtype)
    inputs = dict(np.load(args.inputs))
    record = {
        "benchmark": "rom_batch_throughput_pytorch_peer", "device": device_name(device), "backend": "PyTorch",
        "threads": torch.get_num_threads() if device.type == "cpu" else None,
        "precision": "double" if dtype == torch.float64 else "float", "torch_version": torch.__version__,
        "scene": str(inputs["scene_name"]), "method": str(inputs["method"]), "selection": str(inputs["selection"]),
        "samples": int(inputs["num_samples"]), "sources": int(len(inputs["source_X"])),
        "nodes": int(len(inputs["nodes"])), "latent_dim": int(inputs["xhat0"].shape[1]), "polar": args.polar,
    }
    with torch.no_grad():
        if args.validate:
            record["validation"] = validate(inputs, dict(np.load(args.validate)), device, dtype, args.polar)
        else:
            record.update(steps=args.steps, warmup=args.warmup)
            record["points"] = benchmark(inputs, args.batch, args.steps, args.warmup, device, dtype, args.polar)
    text = json.dumps(record, indent=1)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")
    else:
        print(text)


if __name__ == "__main__":
    main()
