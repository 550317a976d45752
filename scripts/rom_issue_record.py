#!/usr/bin/env python3
"""A study record (scripts/rom_projection_study.sh's OUT_DIR/<name>.json, rom_at_scale.sh's OUT/<name>.study.json) as
issue 28's record: the headline fields first (position_error, velocity_error, stopped_rollouts, samples, evaluated
points; test runs), then the device and the reference where known, the study record kept whole under study_record.
Usage: rom_issue_record.py STUDY_RECORD OUT SCENE METHOD COMMIT"""
import json
import os
import sys

if len(sys.argv) != 6:
    sys.exit(__doc__.splitlines()[-1])
src, dst, scene, method, commit = sys.argv[1:]
if os.path.exists(dst) and not os.path.isfile(dst):  # written as dst.tmp, then renamed over it
    sys.exit(f"rom_issue_record: error: {dst} exists and is not a regular file")
record = json.load(open(src))
errors, rollout = record["errors"]["test"], record["rollout"]
reduction = rollout["hyper_reduction"]
out = {"scene": scene, "method": method, "runs": "test", "samples": reduction["samples"],
       "evaluated_points": reduction.get("evaluated_points") or reduction["source_points"] or reduction["samples"],
       "position_error": errors["position_error"], "velocity_error": errors["velocity_error"],
       "stopped_rollouts": rollout["stopped_rollouts"], "flags": record["flags"], "model": record["model"],
       "commit": commit}
# Where the rollout ran and what it was compared with, when the records say (scripts/rom_at_scale.sh's do).
out.update({key: rollout[key] for key in ("device", "backend", "precision") if key in rollout})
if "reference" in record:
    out["reference"] = record["reference"]
out["study_record"] = record
with open(dst + ".tmp", "w") as f:
    json.dump(out, f, indent=1)
os.replace(dst + ".tmp", dst)
print(f"{dst}: position {100 * errors['position_error']:.3g} %, velocity {100 * errors['velocity_error']:.3g} %, "
      f"stopped {rollout['stopped_rollouts']}")
