#!/usr/bin/env python3
"""A study record (scripts/rom_projection_study.sh's OUT_DIR/<name>.json) as issue 28's record: the headline fields
first (position_error, velocity_error, stopped_rollouts, samples, evaluated points; test runs), the study record
kept whole under study_record.
Usage: rom_issue_record.py STUDY_RECORD OUT SCENE METHOD COMMIT"""
import json
import os
import sys

if len(sys.argv) != 6:
    sys.exit(__doc__.splitlines()[-1])
src, dst, scene, method, commit = sys.argv[1:]
record = json.load(open(src))
errors, rollout = record["errors"]["test"], record["rollout"]
reduction = rollout["hyper_reduction"]
out = {"scene": scene, "method": method, "runs": "test", "samples": reduction["samples"],
       "evaluated_points": reduction["source_points"] or reduction["samples"],
       "position_error": errors["position_error"], "velocity_error": errors["velocity_error"],
       "stopped_rollouts": rollout["stopped_rollouts"], "flags": record["flags"], "model": record["model"],
       "commit": commit, "study_record": record}
with open(dst + ".tmp", "w") as f:
    json.dump(out, f, indent=1)
os.replace(dst + ".tmp", dst)
print(f"{dst}: position {100 * errors['position_error']:.3g} %, velocity {100 * errors['velocity_error']:.3g} %, "
      f"stopped {rollout['stopped_rollouts']}")
