#!/usr/bin/env bash
# A fuzzing campaign to run by hand, outside CI (which runs fixed, repeatable fuzz runs: scripts/sanitize.sh): each
# chosen libFuzzer target for SECONDS (default 600) from a random seed, on the sanitizer build
# (scripts/sanitize-build.sh, build/sanitize/ or SANITIZE_BUILD_DIR). The inputs that reach new code are kept in
# fuzz/campaign/TARGET/corpus/ (not committed; the next campaign starts from them and from fuzz/corpus/TARGET/), an
# input that crashes, hangs, leaks or runs out of memory in fuzz/campaign/TARGET/crashes/, with the steps that make
# it a regression seed printed on stderr.
# Prints one summary line on stdout; a finding or a failed build ends it with one "fuzz: error: ..." line and exit 1.
# Usage: scripts/fuzz.sh [scene|hdf5|all] [SECONDS]      (FUZZ_SEED=N repeats a campaign's seed)
set -euo pipefail
exec 3>&1 1>&2  # fd 3 is the result (the summary line); everything else goes to stderr
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
which=${1:-all}
seconds=${2:-600}
case "$which" in
  scene|hdf5) targets=("$which");;
  all) targets=(scene hdf5);;
  *) echo "fuzz: error: the fuzzer must be scene, hdf5 or all, not '$which'"; exit 2;;
esac
[[ "$seconds" =~ ^[1-9][0-9]*$ ]] || { echo "fuzz: error: SECONDS must be a whole number > 0, not '$seconds'"; exit 2; }
build_dir=$("$here/scripts/sanitize-build.sh" "${targets[@]/#/fuzz_}")
seed=${FUZZ_SEED:-$((RANDOM * 32768 + RANDOM + 1))}  # libFuzzer takes 0 as "choose one"
echo "fuzz: seed $seed (FUZZ_SEED=$seed scripts/fuzz.sh $which $seconds mutates the same way, timing allowing)"

# How to keep what a target found, printed when it finds something.
regression_steps() {  # TARGET INPUT
  local extension=toml
  [ "$1" = hdf5 ] && extension=h5
  cat <<EOF
fuzz: to turn $2 into a regression seed:
  1. reproduce it: $build_dir/fuzz/fuzz_$1 $2
     (shrink it first if you like: $build_dir/fuzz/fuzz_$1 -minimize_crash=1 -runs=100000 $2)
  2. fix the cause and add a unit test for it; the command of step 1 must then run cleanly
  3. keep it: cp $2 $here/fuzz/corpus/$1/regression_WHAT_IT_FOUND.$extension
     and commit it with the fix: CI (scripts/sanitize.sh) replays every seed; list the finding in docs/reliability.md
EOF
}

summary=""
found=()
for target in "${targets[@]}"; do
  campaign="$here/fuzz/campaign/$target"
  mkdir -p "$campaign/corpus" "$campaign/crashes"
  before=$(find "$campaign/corpus" -type f | wc -l)
  echo "fuzz: fuzz_$target for $seconds s; log in $campaign/log"
  if (cd "$build_dir/fuzz" && "./fuzz_$target" -seed="$seed" -max_total_time="$seconds" -timeout=20 \
      -rss_limit_mb=4096 -print_final_stats=1 -artifact_prefix="$campaign/crashes/" \
      "$campaign/corpus" "$here/fuzz/corpus/$target" 2> "$campaign/log"); then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$campaign/log")
    added=$(($(find "$campaign/corpus" -type f | wc -l) - before))
    summary+="${summary:+; }fuzz_$target ${runs:-?} runs, $added new inputs"
  else
    grep -E "ERROR|SUMMARY|runtime error" "$campaign/log" | head -5 || true
    input=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$campaign/log" | tail -1)
    found+=("fuzz_$target: ${input:-see $campaign/log}")
    if [ -n "$input" ]; then regression_steps "$target" "$input"; fi
  fi
done
if [ ${#found[@]} -gt 0 ]; then
  echo "fuzz: error: seed $seed, found: ${found[*]}"
  exit 1
fi
echo "fuzz: seed $seed, $seconds s each: $summary; nothing found" >&3
