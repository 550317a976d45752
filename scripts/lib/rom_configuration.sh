# Sourced by the reduced-model studies (rollout_defaults.sh, rom_projection_study.sh, rom_at_scale.sh): a sweep's
# parameter values, and one configuration rolled out over them and evaluated against the full-order runs.

# design_params DESIGN_CSV OUT [SPLIT]: the design's parameter values (every column but split and file) as a --params
# file, the rows of SPLIT only when given.
design_params() {
  python3 - "$1" "$2" "${3:-}" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
names = [k for k in rows[0] if k not in ("split", "file")]
with open(sys.argv[2], "w") as f:
    f.write(",".join(names) + "\n")
    for row in rows:
        if not sys.argv[3] or row["split"] == sys.argv[3]:
            f.write(",".join(row[n] for n in names) + "\n")
PY
}

# rom_configuration SCRIPT MPMROM MODEL SCENE PARAMS DATA FILE [FLAGS...]: writes FILE.h5, FILE.rollout.json (the
# rollout's --json record) and FILE.errors.json (evaluate --json); a batch in which some rollouts stopped (exit 3)
# is a result, any other failure ends the calling script with one line naming SCRIPT.
rom_configuration() {
  local script=$1 mpmrom=$2 model=$3 scene=$4 params=$5 data=$6 file=$7 status=0
  shift 7
  "$mpmrom" -q rollout "$model" "$scene" --out "$file.h5" --params "$params" "$@" --json > "$file.rollout.json" ||
    status=$?
  [ "$status" -eq 0 ] || [ "$status" -eq 3 ] || { echo "$script: error: rollout $* exited $status" >&2; exit 1; }
  "$mpmrom" -q evaluate "$file.h5" "$data" --json > "$file.errors.json"
}
