#!/usr/bin/env bash
# Pictures of a pipeline's results: a full-order test run and the reduced model at the same parameters (Algorithm 1,
# every point, decoded at the model's points), each as a PNG of its last frame, PNGs of every frame and an animated
# GIF (scripts/render.sh: ParaView, headless), in PIPELINE_DIR/pictures/.
# Fails with one line when a picture is missing at the end. Prints nothing on stdout.
# Usage: scripts/pictures.sh PIPELINE_DIR SCENE [BUILD_DIR]   (RENDER_OPTIONS: more scripts/render.py options)
set -euo pipefail
exec 1>&2  # no result on stdout: the pictures are files
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dir=${1:?usage: pictures.sh PIPELINE_DIR SCENE [BUILD_DIR]}
scene=${2:?scene file}
mpmrom=${3:-$here/build/double}/apps/mpmrom
out="$dir/pictures"
mkdir -p "$out"
# The first test run: its parameters (every design column before split) and its snapshot.
python3 - "$dir/data/design.csv" "$out/params.csv" > "$out/run.txt" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
row = next(r for r in rows if r["split"] == "test")
names = [k for k in rows[0] if k not in ("split", "file")]
with open(sys.argv[2], "w") as f:
    f.write(",".join(names) + "\n" + ",".join(row[n] for n in names) + "\n")
print(row["file"], ", ".join("%s = %g" % (n, float(row[n])) for n in names))
PY
read -r run values < "$out/run.txt"
model=$(ls "$dir"/models/*.h5 | head -n 1)
"$mpmrom" -q rollout "$model" "$scene" --out "$out/rom.h5" --params "$out/params.csv" --samples 0 --decode reference
name=$(basename "$scene" .toml)
rm -f "$out/${name}"_{fom,rom}.{png,gif}  # a picture left from an earlier run must not pass for this one
"$here/scripts/render.sh" "$dir/data/${run%.h5}.xmf" --out "$out" --name "${name}_fom" ${RENDER_OPTIONS:-} \
  --title "$name, full-order MPM ($values)"
"$here/scripts/render.sh" "$out/rom.xmf" --out "$out" --name "${name}_rom" ${RENDER_OPTIONS:-} \
  --title "$name, reduced model $(basename "$model" .h5), all points ($values)"
for kind in fom rom; do
  for picture in "$out/${name}_$kind.png" "$out/${name}_$kind.gif"; do
    [ -s "$picture" ] || { echo "pictures: error: $picture was not made"; exit 1; }
  done
done
echo "pictures: $out/${name}_fom.{png,gif} and ${name}_rom.{png,gif}"
