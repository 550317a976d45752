#!/usr/bin/env bash
# The reduced model at scale (docs/results/rom/README.md "At 10^5 points"): a scene's sweep, models trained on it and
# rollouts of its test runs evaluated against it, all in WORK (the sweep in WORK/data). Made for a GPU machine with no
# access to the sweep it would take hours to make on 2 cores: every step runs where the script runs.
#   rom_at_scale.sh train SCENE "NAME|TRAIN FLAGS"...         sweep (unless WORK/data has one), then WORK/NAME.h5
#   rom_at_scale.sh rollouts SCENE "MODEL|NAME|ROLLOUT FLAGS"...  WORK/MODEL.h5 (or MODEL, a path) over the test runs
# Environment: MPMROM (the binary; default build/double/apps/mpmrom), WORK (default out/at_scale), OUT (records:
# OUT/NAME.train.json; per rollout OUT/MODEL_NAME.rollout.json (rollout --json), .errors.json (evaluate --json, test
# runs), .study.json (both with the configuration) and .record.json (issue 28's record, scripts/rom_issue_record.py);
# default WORK/records). One line per step on stdout; a failing step fails the script.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage="usage: rom_at_scale.sh train|rollouts SCENE CONFIG..."
verb=${1:?$usage}; scene=${2:?$usage}; shift 2
mpmrom=${MPMROM:-$here/build/double/apps/mpmrom}
work=${WORK:-$here/out/at_scale}
out=${OUT:-$work/records}
mkdir -p "$work" "$out"
source "$here/scripts/lib/rom_configuration.sh"

# OUT/STEM.study.json: the rollout's and evaluate's records with the configuration (rom_issue_record.py's input).
study_record() {
  python3 - "$out/$1" "$2" "$3" "$4" "$work/data" <<'PY'
import json, sys
stem, name, model, flags, reference = sys.argv[1:6]
rollout = json.load(open(stem + ".rollout.json"))
record = {"name": name, "flags": flags, "model": model, "commit": rollout["git_commit"][:7], "runs": "test",
          "reference": reference, "errors": json.load(open(stem + ".errors.json")), "rollout": rollout}
json.dump(record, open(stem + ".study.json", "w"), indent=1)
PY
}

case $verb in
  train)
    if [ ! -f "$work/data/design.csv" ]; then
      start=$SECONDS
      "$mpmrom" -q sweep "$scene" --out "$work/data"
      echo "sweep: $((SECONDS - start)) s"
    fi
    for config in "$@"; do
      IFS='|' read -r name flags <<< "$config"
      read -r -a train_flags <<< "$flags"
      start=$SECONDS
      "$mpmrom" -q train "$work/data" --out "$work/$name.h5" "${train_flags[@]}" --json > "$out/$name.train.json"
      echo "train $name: $((SECONDS - start)) s"
    done
    ;;
  rollouts)
    design_params "$work/data/design.csv" "$work/test_params.csv" test
    [ "$(wc -l < "$work/test_params.csv")" -gt 1 ] ||
      { echo "rom_at_scale: error: no test runs in $work/data" >&2; exit 1; }
    for config in "$@"; do
      IFS='|' read -r model name flags <<< "$config"
      read -r -a rollout_flags <<< "$flags"
      path=$work/$model.h5
      [ -f "$path" ] || path=$model
      stem=$(basename "$model" .h5)_$name
      start=$SECONDS
      rom_configuration rom_at_scale "$mpmrom" "$path" "$scene" "$work/test_params.csv" "$work/data" "$work/$stem" \
        "${rollout_flags[@]}"
      mv "$work/$stem.rollout.json" "$work/$stem.errors.json" "$out/"
      study_record "$stem" "$name" "$path" "$flags"
      method=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["settings"]["method"])' \
        "$out/$stem.rollout.json")
      # the binary's commit, not the checkout's: it may have moved during a long run
      commit=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["commit"])' "$out/$stem.study.json")
      python3 "$here/scripts/rom_issue_record.py" "$out/$stem.study.json" "$out/$stem.record.json" \
        "$(basename "$scene" .toml)" "$method" "$commit" >&2
      echo "rollout $stem: $((SECONDS - start)) s"
    done
    ;;
  *) echo "$usage" >&2; exit 2 ;;
esac
