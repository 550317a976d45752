#!/usr/bin/env python3
"""An issue-29 speedup record: a rollout's study record (scripts/rom_at_scale.sh's OUT/<name>.study.json: the test
runs, full horizon, with their errors) beside the full-order step on the same scene from the same build and device
(`mpmrom bench fom SCENE --json`). Per simulated second, the ROM's cost is its batch time over the simulated time and
the rollouts (rollout --json's rom_seconds_per_simulated_second), the FOM's its step time over its time step (bench
fom's dt_s, the scene's CFL step at rest). Writes OUT (atomically) and prints one line on stdout.
Usage: rom_speedup_record.py STUDY_RECORD FOM_BENCH_JSON OUT"""
import json
import os
import sys

if len(sys.argv) != 4:
    sys.exit(__doc__.splitlines()[-1])
study_path, fom_path, dst = sys.argv[1:]
if os.path.exists(dst) and not os.path.isfile(dst):  # written as dst.tmp, then renamed over it
    sys.exit(f"rom_speedup_record: error: {dst} exists and is not a regular file")
study, fom = json.load(open(study_path)), json.load(open(fom_path))
rollout, errors = study["rollout"], study["errors"]["test"]
if rollout["scene"] != fom["scene"]:
    sys.exit(f"rom_speedup_record: error: the rollout is of {rollout['scene']}, the FOM bench of {fom['scene']}")
reduction = rollout["hyper_reduction"]
fom_per_second = fom["fom_step_seconds"] / fom["dt_s"]
rom_per_second = rollout["rom_seconds_per_simulated_second"]
# records before the stepper counted them: Algorithm 1's sources, else the samples alone
evaluated = reduction.get("evaluated_points") or reduction["source_points"] or reduction["samples"]
record = {
    "scene": rollout["scene"], "method": rollout["settings"]["method"], "device": rollout["device"],
    "backend": rollout["backend"], "precision": rollout["precision"], "particles": rollout["particles"],
    "samples": reduction["samples"], "evaluated_points": evaluated,
    "rom_seconds_per_simulated_second": rom_per_second, "fom_seconds_per_simulated_second": fom_per_second,
    "speedup_per_simulated_second": fom_per_second / rom_per_second,
    "position_error": errors["position_error"], "velocity_error": errors["velocity_error"],
    "stopped_rollouts": rollout["stopped_rollouts"], "rollouts": rollout["rollouts"], "runs": "test",
    "rom_steps": rollout["steps"], "fom_step_seconds": fom["fom_step_seconds"], "fom_dt_s": fom["dt_s"],
    "flags": study["flags"], "model": study["model"], "commit": study["commit"], "fom_bench": fom,
    "study_record": study}
with open(dst + ".tmp", "w") as f:
    json.dump(record, f, indent=1)
os.replace(dst + ".tmp", dst)
print(f"{dst}: {record['speedup_per_simulated_second']:.3g}x per simulated second, position "
      f"{100 * errors['position_error']:.3g} %, velocity {100 * errors['velocity_error']:.3g} %, stopped "
      f"{rollout['stopped_rollouts']}")
