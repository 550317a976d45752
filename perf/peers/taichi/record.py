#!/usr/bin/env python3
"""One peer record from the run's parts: ours (`mpmrom bench fom --json`, timed before and after the peer's, so that
a drift of the machine's speed weighs on both alike; the mean counts), the peer's timings (`mpm_taichi.py ...
bench`, one per layout) and the agreement (`agree.py`). Prints the record (JSON) on stdout.

Usage: record.py OURS_BEFORE.json OURS_AFTER.json AGREE.json PEER.json... [--peak-bandwidth BYTES_PER_S]
"""
import argparse
import json
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("ours_before")
    parser.add_argument("ours_after")
    parser.add_argument("agree")
    parser.add_argument("peers", nargs="+")
    parser.add_argument("--peak-bandwidth", type=float, default=0.0,
                        help="the device's memory bandwidth (bytes/s) for the step's traffic bound; 0: none")
    args = parser.parse_args()
    load = lambda path: json.load(open(path))
    before, after = load(args.ours_before), load(args.ours_after)
    agree, peers = load(args.agree), [load(p) for p in args.peers]
    ours = dict(before, fom_particle_steps_per_s=0.5 * (before["fom_particle_steps_per_s"] +
                                                        after["fom_particle_steps_per_s"]))
    for peer in peers:
        if peer["particles"] != ours["particles"] or peer["precision"] != ours["precision"]:
            sys.exit(f"record.py: {peer['layout']} ran {peer['particles']} {peer['precision']} particles, ours "
                     f"{ours['particles']} {ours['precision']}")
    best = max(peers, key=lambda p: p["particle_steps_per_s"])
    record = {
        "benchmark": "peer_fom", "peer": "taichi", "scene": ours["scene"], "device": ours["device"],
        "backend": ours["backend"], "precision": ours["precision"], "threads": ours["threads"],
        "particles": ours["particles"], "grid_nodes": ours["grid_nodes"], "p2g": ours["p2g"], "dt_s": ours["dt_s"],
        "steps": ours["steps"], "git_commit": ours["git_commit"], "kokkos_version": ours["kokkos_version"],
        "taichi_version": best["taichi_version"],
        "fom_particle_steps_per_s": ours["fom_particle_steps_per_s"],
        "fom_particle_steps_per_s_before_after": [before["fom_particle_steps_per_s"],
                                                  after["fom_particle_steps_per_s"]],
        "peer_particle_steps_per_s": best["particle_steps_per_s"], "peer_layout": best["layout"],
        "peer_layouts": {p["layout"]: p["particle_steps_per_s"] for p in peers},
        "ratio_vs_peer": ours["fom_particle_steps_per_s"] / best["particle_steps_per_s"],
        "agreement": agree,
    }
    if args.peak_bandwidth > 0:
        # The step's own traffic (bench fom's byte counts: every particle field read and written once, the grid
        # cleared, filled and read) at the device's peak bandwidth: the particle-steps/s no step can beat.
        bytes_per_particle_step = (ours["particle_bytes_per_step"] + ours["grid_bytes_per_step"]) / ours["particles"]
        bound = args.peak_bandwidth / bytes_per_particle_step
        record.update(peak_bandwidth_bytes_per_s=args.peak_bandwidth, traffic_bound_particle_steps_per_s=bound,
                      fom_share_of_bound=ours["fom_particle_steps_per_s"] / bound,
                      peer_share_of_bound=best["particle_steps_per_s"] / bound)
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
