#!/usr/bin/env bash
# CI's sanitizer job: the sanitizer build (scripts/sanitize-build.sh: clang, AddressSanitizer and
# UndefinedBehaviorSanitizer against Debian's Serial Kokkos, in build/sanitize/ or SANITIZE_BUILD_DIR) runs the
# whole test suite, then each libFuzzer target runs its seed corpus (fuzz/corpus/scene, fuzz/corpus/hdf5) and a
# fixed number of mutations of it from a fixed seed: the same code tries the same inputs, so a green run stays green
# and a red one reproduces. Longer, randomised campaigns: scripts/fuzz.sh.
# Prints nothing on stdout; any test failure, sanitizer report or fuzzer crash ends it with one line naming the
# failed parts and exit 1. A crashing input is kept as build/sanitize/fuzz/crash-* (docs/reliability.md: making it
# a regression seed).
set -euo pipefail
exec 1>&2  # no result to print: everything below is progress
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=$("$here/scripts/sanitize-build.sh")
failed=()

echo "== tests under ASan + UBSan (Serial) =="
# detect_leaks: Kokkos and HDF5 keep process-lifetime allocations; leaks are checked in the fuzzers' own runs.
# Left out here, not in the normal builds: the two trainings that run the trainer's kernels for hundreds of epochs
# to check what the model learns (over 8 minutes under ASan on 2 cores); the same kernels run under the sanitizers
# in test_trainer's shorter trainings (SameSeedSameModelOtherSeedOtherModel, ResumesAKilledRunBitForBit).
long_trainings=-Trainer.FitsATwistingBar:Trainer.AffineTermTeachesTheVelocityGradient
(cd "$build_dir" && ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 GTEST_FILTER=$long_trainings \
  ctest --output-on-failure --timeout 1800) || failed+=(tests)

# About 60 s each on 2 cores (docs/reliability.md). Runs repeat exactly only where heap addresses do (pointer values
# reach the fuzzer's comparison tables): no address randomisation, and the corpus named by a relative path (its
# length moves later allocations); and without re-reading the corpus folder on a timer (-reload=0).
scene_runs=1300000
hdf5_runs=28000
fixed_addresses=(setarch "$(uname -m)" -R)
"${fixed_addresses[@]}" true 2> /dev/null ||
  { fixed_addresses=(); echo "sanitize: address randomisation cannot be turned off here: fuzz runs may differ"; }

# fuzz TARGET RUNS: the target's seed corpus, then RUNS inputs in all from -seed=1, in a copy of the corpus
# (build/sanitize/fuzz/run_TARGET/corpus).
fuzz() {
  local work="$build_dir/fuzz/run_$1"
  echo "== fuzz_$1: $2 runs from -seed=1 over fuzz/corpus/$1 =="
  rm -rf "$work" && mkdir -p "$work/corpus" && cp "$here/fuzz/corpus/$1/"* "$work/corpus/"
  (cd "$build_dir/fuzz" && "${fixed_addresses[@]}" "./fuzz_$1" -seed=1 -runs="$2" -reload=0 -timeout=20 \
    -rss_limit_mb=4096 -print_final_stats=1 "run_$1/corpus" 2> "$work/log") || failed+=("fuzz_$1")
  grep -E "^(stat::number_of_executed_units|#[0-9]+[[:space:]]+(INITED|DONE))|ERROR|SUMMARY|[Tt]imeout" \
    "$work/log" || true
}
fuzz scene "$scene_runs"
fuzz hdf5 "$hdf5_runs"

if [ ${#failed[@]} -gt 0 ]; then
  echo "sanitize: error: failed: ${failed[*]} (logs above; crashing inputs in $build_dir/fuzz/)"
  exit 1
fi
