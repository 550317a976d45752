#!/usr/bin/env bash
# Scaling of the MPI build (docs/mpi.md) on one host: the sweep, training and batch rollouts on 1 and NP processes
# (one GPU each on a GPU build), every run through mpirun, as one benchmark record
# RESULTS/mpi_scaling_<backend>_<precision><SUFFIX>.json. Rollouts: strong scaling (the same batch on 1 and NP
# processes) and weak scaling (batch/NP on one process against the batch on NP), each timed over one output interval
# of the scene as in run_batch_bench.sh (setup and output untimed; the ranks' slowest stepping time counts).
# Usage: perf/run_mpi_scaling.sh BUILD_DIR MODEL SCENE [NP]
#   MODEL: a trained model of SCENE. ROLLOUTS (default "10000 100000"): batch sizes; CONFIGS (default
#   "point:15 node:15"); EPOCHS (default 20) of the timed training runs; TIMEOUT (default 300) seconds per run;
#   SWEEP_SCENE (default SCENE): the scene whose design the timed sweeps run; SUFFIX tags the record's name;
#   RESULTS (default perf/results). Each process gets nproc / P OpenMP threads.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:?usage: run_mpi_scaling.sh BUILD_DIR MODEL SCENE [NP]}
model=${2:?model file}
scene=${3:?scene file}
np=${4:-2}
rollouts=${ROLLOUTS:-"10000 100000"}
configs=${CONFIGS:-"point:15 node:15"}
epochs=${EPOCHS:-20}
results=${RESULTS:-$here/perf/results}
export OMP_PROC_BIND=${OMP_PROC_BIND:-false}
mpmrom="$build/apps/mpmrom"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
log="$work/runs.jsonl"
: > "$log"
on() {  # on P ARGS...: mpmrom ARGS on P processes, the host's cores shared among them
  local p=$1
  shift
  OMP_NUM_THREADS=$(( $(nproc) / p > 0 ? $(nproc) / p : 1 )) \
    timeout "${TIMEOUT:-300}" mpirun -np "$p" --oversubscribe --bind-to none -x OMP_NUM_THREADS "$mpmrom" -q "$@"
}
seconds() { python3 -c 'import time; print(time.monotonic())'; }
interval=$(python3 -c 'import sys, tomllib; t = tomllib.load(open(sys.argv[1], "rb"))["time"]; print(t["end_time"] / t["outputs"])' "$scene")

sweep_scene=${SWEEP_SCENE:-$scene}
for p in 1 "$np"; do
  start=$(seconds)
  on "$p" sweep "$sweep_scene" --out "$work/sweep_$p"
  echo "{\"kind\": \"sweep\", \"scene\": \"$(basename "$sweep_scene" .toml)\", \"processes\": $p, \"seconds\": $(python3 -c "print($(seconds) - $start)"), \"runs\": $(($(wc -l < "$work/sweep_$p/design.csv") - 1))}" >> "$log"
  echo "sweep on $p: $(tail -1 "$log")" >&2
done
# the training runs learn the rollout scene's sweep
if [ "$sweep_scene" != "$scene" ]; then
  rm -rf "$work/sweep_1" "$work/sweep_$np"
  on "$np" sweep "$scene" --out "$work/sweep_1"
fi
for minibatch in "8 128" "64 1024"; do
  set -- $minibatch
  for p in 1 "$np"; do
    on "$p" train "$work/sweep_1" --out "$work/model_$p.h5" --epochs "$epochs" --batch-snapshots "$1" \
       --points-per-snapshot "$2" --json | python3 -c '
import json, sys
r = json.loads(sys.stdin.read().strip().splitlines()[-1])
print(json.dumps({"kind": "train", "processes": int(sys.argv[1]), "batch_snapshots": int(sys.argv[2]),
                  "points_per_snapshot": int(sys.argv[3]), "epochs": int(sys.argv[4]),
                  "samples_per_s": r["training_samples_per_s"], "training_seconds": r["training_seconds"],
                  "runtime": {k: r[k] for k in ("backend", "device", "precision", "kokkos_version", "git_commit")}}))
' "$p" "$1" "$2" "$epochs" >> "$log"
    echo "train ($1 x $2) on $p: $(tail -1 "$log")" >&2
  done
done
for config in $configs; do
  method=${config%%:*} n=${config##*:}
  for batch in $rollouts; do
    for run in "1 $batch" "$np $batch" "1 $((batch / np))"; do
      set -- $run
      python3 "$here/perf/design_params.py" "$scene" "$2" "$work/params.csv"
      status=0
      # region selection, as in the committed records: a step's cost depends on how many samples, not which
      on "$1" rollout "$model" "$scene" --out "$work/rom.h5" --method "$method" --samples "$n" --selection region \
         --params "$work/params.csv" --end-time "$interval" --json > "$work/record.json" 2> "$work/err" || status=$?
      # exit 3: some rollouts stopped (the record is written all the same)
      if [ "$status" -eq 0 ] || { [ "$status" -eq 3 ] && [ -s "$work/record.json" ]; }; then
        python3 -c '
import json, sys
r = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
print(json.dumps({"kind": "rollout", "method": sys.argv[2], "samples": int(sys.argv[3]), "processes": int(sys.argv[4]),
                  "rollouts": r["rollouts"], "steps": r["steps"], "rom_step_seconds": r["rom_step_seconds"],
                  "rom_rollout_steps_per_s": r["rom_rollout_steps_per_s"], "setup_seconds": r["setup_seconds"]}))
' "$work/record.json" "$method" "$n" "$1" >> "$log"
      else
        echo "{\"kind\": \"rollout\", \"method\": \"$method\", \"processes\": $1, \"rollouts\": $2, \"error\": $(tail -1 "$work/err" | python3 -c 'import json,sys; print(json.dumps(sys.stdin.read().strip()))')}" >> "$log"
      fi
      rm -f "$work/rom.h5"
      echo "rollout $method $n, $2 on $1: $(tail -1 "$log")" >&2
    done
  done
done

python3 - "$log" "$results" "$np" "${SUFFIX:-}" "$(basename "$scene" .toml)" "$epochs" <<'PY'
import json, sys
path, results, np, suffix, scene, epochs = sys.argv[1:]
np = int(np)
runs = [json.loads(line) for line in open(path)]
runtime = next(r["runtime"] for r in runs if r["kind"] == "train")
record = {"benchmark": "mpi_scaling", "scene": scene, "processes": np, **runtime,
          "method": "every run through mpirun on one host, one GPU per process on a GPU build; rollouts timed over "
                    "one output interval (the ranks' slowest stepping time), training samples/s over the epochs",
          "runs": runs}
def find(kind, **keys):
    return next((r for r in runs if r["kind"] == kind and "error" not in r
                 and all(r.get(k) == v for k, v in keys.items())), None)
summary = []
one, many = find("sweep", processes=1), find("sweep", processes=np)
if one and many:
    summary.append({"what": "sweep (%d runs)" % one["runs"], "speedup": one["seconds"] / many["seconds"],
                    "efficiency": one["seconds"] / many["seconds"] / np})
for r in runs:
    if r["kind"] == "train" and r["processes"] == np:
        base = find("train", processes=1, batch_snapshots=r["batch_snapshots"])
        if base:
            speedup = r["samples_per_s"] / base["samples_per_s"]
            summary.append({"what": "train %dx%d (strong)" % (r["batch_snapshots"], r["points_per_snapshot"]),
                            "speedup": speedup, "efficiency": speedup / np})
    if r["kind"] == "rollout" and r["processes"] == np and "error" not in r:
        strong = find("rollout", processes=1, method=r["method"], rollouts=r["rollouts"])
        weak = find("rollout", processes=1, method=r["method"], rollouts=r["rollouts"] // np)
        if strong:
            speedup = r["rom_rollout_steps_per_s"] / strong["rom_rollout_steps_per_s"]
            summary.append({"what": "rollout %s batch %d (strong)" % (r["method"], r["rollouts"]),
                            "speedup": speedup, "efficiency": speedup / np})
        if weak:
            # same work per process: the time of a step should stay the same
            summary.append({"what": "rollout %s %d per process (weak)" % (r["method"], r["rollouts"] // np),
                            "efficiency": weak["rom_step_seconds"] / r["rom_step_seconds"]})
record["summary"] = summary
name = "%s/mpi_scaling_%s_%s%s.json" % (results, runtime["backend"].lower(), runtime["precision"], suffix)
json.dump(record, open(name, "w"), indent=1)
for s in summary:
    print("%-40s %s" % (s["what"], "  ".join("%s %.3g" % (k, v) for k, v in s.items() if k != "what")))
print("wrote", name)
PY
