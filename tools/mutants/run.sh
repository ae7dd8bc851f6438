#!/usr/bin/env bash
# Mutation testing of the core crates (evogs-math, evogs-ode, evogs-splat) with cargo-mutants.
#
#   tools/mutants/run.sh                      # all three crates, every mutant
#   tools/mutants/run.sh evogs-ode            # one crate
#   tools/mutants/run.sh evogs-math --shard 3/8   # one shard (any cargo-mutants flags follow)
#   tools/mutants/run.sh --in-diff changes.diff   # only mutants on the changed lines
#
# Results go to target/mutants/CRATE/mutants.out (caught.txt, missed.txt, unviable.txt,
# timeout.txt, outcomes.json); a line per crate with the counts is printed at the end and
# docs/testing.md holds the last full run. Install once: cargo install cargo-mutants --locked.
set -euo pipefail
cd "$(dirname "$0")/../.."

crates=()
while [ $# -gt 0 ] && [[ "$1" != -* ]]; do
    crates+=("$1")
    shift
done
[ ${#crates[@]} -gt 0 ] || crates=(evogs-math evogs-ode evogs-splat)

if ! cargo mutants --version >/dev/null 2>&1; then
    echo "cargo-mutants is not installed: cargo install cargo-mutants --locked" >&2
    exit 2
fi

count() { if [ -f "$1" ]; then grep -c . "$1" || true; else echo 0; fi; }  # grep -c prints 0 for an empty file

status=0
for c in "${crates[@]}"; do
    out="target/mutants/$c"
    mkdir -p "$out"
    # A missed mutant makes cargo-mutants exit 2; the summary below still prints.
    # --all-features: the property tests (feature `proptest`) and the interop round trips
    # are part of what catches a mutant.
    # --profile mutants (Cargo.toml): the builds, which are the cost, at opt-level 1.
    cargo mutants -p "$c" --all-features --profile mutants -o "$out" --timeout 120 "$@" || status=$?
    d="$out/mutants.out"
    caught=$(count "$d/caught.txt")
    missed=$(count "$d/missed.txt")
    unviable=$(count "$d/unviable.txt")
    timeout=$(count "$d/timeout.txt")
    viable=$((caught + missed + timeout))
    pct=$(awk -v c="$caught" -v v="$viable" 'BEGIN { if (v > 0) printf "%.1f", 100 * c / v; else print "n/a" }')
    echo "$c: caught $caught, missed $missed, timeout $timeout, unviable $unviable ($pct % of viable mutants caught)"
done
exit "$status"
