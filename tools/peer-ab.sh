#!/usr/bin/env bash
# Side by side with the PyTorch-CPU peer, for two evogs binaries at once (before and after a
# change): per N and round, the peer, then each binary, alternating, 2 threads each, 5 timed
# iterations after 2 warm-up ones. Prints every round (seconds per iteration, and evogs's
# peak RSS in MiB), then per N the median of the round medians and the ratios.
#
#   PEER=path/to/evogs_torch.py PY=path/to/python tools/peer-ab.sh BEFORE AFTER [N ...]
#
# PEER is the peer program (it is not part of this repository: docs/results.md says where it
# comes from and how to install its Python); default N = 20000 5000.
set -euo pipefail
PY=${PY:-python3}
PEER=${PEER:?set PEER to the peer program, evogs_torch.py (docs/results.md)}
THREADS=${THREADS:-2}
ROUNDS=${ROUNDS:-3}
[ $# -ge 2 ] || { echo "usage: $0 BEFORE_BINARY AFTER_BINARY [N ...]" >&2; exit 2; }
before=$1 after=$2; shift 2
[ $# -gt 0 ] || set -- 20000 5000
for bin in "$before" "$after"; do [ -x "$bin" ] || { echo "$bin: not an executable" >&2; exit 2; }; done
[ -f "$PEER" ] || { echo "$PEER: no such file" >&2; exit 2; }
ours() { # binary N -> "seconds peak_MiB"
  local j; j=$(mktemp)
  "$1" bench --gaussians "$2" --sizes paper --motions velocity --no-single-thread \
    --iters 5 --threads "$THREADS" --json "$j" >/dev/null 2>&1
  "$PY" -c 'import json,sys; r=json.load(open(sys.argv[1]))["rows"][0]; print(r["seconds"]["median"], (r["peak_rss_bytes"] or 0) >> 20)' "$j"
  rm -f "$j"
}
for n in "$@"; do
  p=(); b=(); a=()
  for r in $(seq "$ROUNDS"); do
    p+=("$("$PY" "$PEER" bench --n "$n" --res 400 --iters 5 --threads "$THREADS" 2>/dev/null \
      | "$PY" -c 'import json,sys; print(json.loads(sys.stdin.read().strip().splitlines()[-1])["median_s_per_iter"])')")
    rb=$(ours "$before" "$n"); ra=$(ours "$after" "$n")
    b+=("${rb%% *}"); a+=("${ra%% *}")
    echo "N=$n round $r: peer ${p[-1]}  before $rb  after $ra"
  done
  "$PY" - "$n" "${p[*]}" "${b[*]}" "${a[*]}" <<'PY'
import statistics, sys
n = sys.argv[1]
p, b, a = ([float(x) for x in s.split()] for s in sys.argv[2:5])
mp, mb, ma = statistics.median(p), statistics.median(b), statistics.median(a)
print(f"N={n}: peer {mp:.3f}  before {mb:.3f} ({mp/mb:.2f}x)  after {ma:.3f} ({mp/ma:.2f}x)")
PY
done
