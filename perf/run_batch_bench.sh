#!/usr/bin/env bash
# Rollout-steps per second as the batch grows: one record per ROM configuration, holding one point per batch size.
# Each batch cycles through the scene's design runs; each point is one `mpmrom rollout --json` of that batch over
# END_TIME (default: one output interval of the scene), so setup and output are not timed (rom_step_seconds is the
# mean wall time of one batch step, fenced).
# Usage: perf/run_batch_bench.sh BUILD_DIR MODEL SCENE [BATCHES] [END_TIME]
#   BATCHES: space-separated batch sizes (default "1 10 100 1000 10000 100000")
#   CONFIGS="point:15 node:15" (method:samples) picks the configurations; SUFFIX (e.g. _h200) tags the file names;
#   RESULTS (default perf/results) is where the records go; TIMEOUT (seconds) bounds each batch's run (a batch that
#   runs out of time is recorded as an error).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:?usage: run_batch_bench.sh BUILD_DIR MODEL SCENE [BATCHES] [END_TIME]}
model=${2:?model file}
scene=${3:?scene file}
batches=${4:-"1 10 100 1000 10000 100000"}
end_time=${5:-0}
configs=${CONFIGS:-"point:15 node:15"}
suffix=${SUFFIX:-}
results=${RESULTS:-$here/perf/results}
export OMP_PROC_BIND=${OMP_PROC_BIND:-false}
mpmrom="$build/apps/mpmrom"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ "$end_time" = 0 ]; then
  end_time=$(python3 -c 'import sys, tomllib; t = tomllib.load(open(sys.argv[1], "rb"))["time"]; print(t["end_time"] / t["outputs"])' "$scene")
fi
for config in $configs; do
  method=${config%%:*} n=${config##*:}
  records="$work/records_${method}_${n}.jsonl"
  : > "$records"
  for batch in $batches; do
    python3 "$here/perf/design_params.py" "$scene" "$batch" "$work/params.csv"
    # region selection, as in the committed records: a step's cost depends on how many samples, not which
    if ! ${TIMEOUT:+timeout "$TIMEOUT"} "$mpmrom" -q rollout "$model" "$scene" --out "$work/rom.h5" --method "$method" --samples "$n" --selection region \
        --params "$work/params.csv" --end-time "$end_time" --json >> "$records" 2> "$work/err"; then
      [ -s "$work/err" ] || echo "no result within ${TIMEOUT:-?} s" > "$work/err"
      echo "batch $batch ($method, $n samples) failed: $(tail -1 "$work/err")" >&2
      echo "{\"rollouts\": $batch, \"error\": $(tail -1 "$work/err" | python3 -c 'import json,sys; print(json.dumps(sys.stdin.read().strip()))')}" >> "$records"
      continue
    fi
    rm -f "$work/rom.h5"
    tail -1 "$records" | python3 -c 'import json,sys; d=json.load(sys.stdin); print("%s %s samples, batch %d: %.4g rollout-steps/s, %.4g s per batch step" % (d["settings"]["method"], d["settings"]["samples"], d["rollouts"], d["rom_rollout_steps_per_s"], d["rom_step_seconds"]))' >&2
  done
  python3 - "$records" "$results" "$(basename "$scene" .toml)" "$method" "$n" "$suffix" <<'PY'
import json, sys
path, results, scene, method, samples, suffix = sys.argv[1:]
runs = [json.loads(line) for line in open(path)]
ok = [r for r in runs if "error" not in r]
if not ok:
    sys.exit("no batch size ran")
record = {k: v for k, v in ok[0].items() if k not in ("rollouts", "rom_rollout_steps_per_s", "rom_step_seconds",
                                                      "setup_seconds", "step_seconds_total", "steps")}
record["benchmark"] = "rom_batch_throughput"
record["points"] = [{"batch": r["rollouts"], "error": r["error"]} if "error" in r else
                    {"batch": r["rollouts"], "steps": r["steps"], "rom_step_seconds": r["rom_step_seconds"],
                     "rom_rollout_steps_per_s": r["rom_rollout_steps_per_s"], "setup_seconds": r["setup_seconds"]}
                    for r in runs]
name = "rom_batch_%s_%s_samples%s_%s_%s%s.json" % (scene, method, samples, record["backend"].lower(),
                                                   record["precision"], suffix)
with open("%s/%s" % (results, name), "w") as f:
    json.dump(record, f)
    f.write("\n")
print("%s/%s" % (results, name), file=sys.stderr)
PY
done
