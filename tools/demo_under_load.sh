#!/usr/bin/env bash
# Ten `make demo` runs in a row beside two CPU-bound processes, the first from an empty numba
# cache (a robot's busy computer on a first run). Prints one line per run; exits 1 if any failed.
set -u
cd "$(dirname "$0")/.."
runs=${1:-10}
python3 -c 'while True: pass' & busy1=$!
python3 -c 'while True: pass' & busy2=$!
trap 'kill $busy1 $busy2 2>/dev/null' EXIT
find human_tracker -name '*.nbi' -delete -o -name '*.nbc' -delete
failed=0
for run in $(seq 1 "$runs"); do
    if output=$(make -s demo 2>&1); then verdict=ok; else verdict=FAILED; failed=$((failed + 1)); fi
    echo "run $run ($verdict): $(grep -m1 '^demo: [0-9]' <<<"$output")"
done
echo "$((runs - failed))/$runs runs passed"
[ "$failed" -eq 0 ]
