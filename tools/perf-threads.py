#!/usr/bin/env python3
"""Where a two-thread `evogs bench` loses its second thread, from a `perf` profile.

Build with frame pointers (so that every sample's stack can be walked), record, and read:

    CARGO_TARGET_DIR=target/fp RUSTFLAGS="-C target-cpu=x86-64-v3 -C force-frame-pointers=yes" \\
        cargo build --release -p evogs-cli
    perf record -F 2999 -g -o perf.data target/fp/release/evogs bench --sizes fast \\
        --motions deformation --no-single-thread --iters 60 --threads 2
    perf script -i perf.data > perf.txt
    tools/perf-threads.py perf.txt serial      # what runs with no parallel pass on the stack
    tools/perf-threads.py perf.txt idle        # what the busy thread does while the other idles

Every sample of a pool thread is one of: **idle** (the thread waits in the pool: rayon's
sleep, steal and wait loops, below any frame of ours), **parallel** (inside a rayon
parallel pass), or **serial** (ours, with no parallel pass on the stack: while it runs the
other thread has nothing to do). `serial` lists the serial samples by their innermost frames
of ours; `idle` pairs every idle sample with the other thread's sample nearest in time
(within 0.7 ms) and lists what that thread was doing: serial stretches, and the tails of
parallel passes whose work did not split evenly. A sample is 1/F seconds of one thread
(0.33 ms at F = 2999); the profile includes the bench's set-up and warm-up iterations.
The matrix products' micro-kernels keep no frame pointer, so their samples carry no stack
and count as serial with an empty key; ignore that row.
"""

import bisect
import collections
import re
import sys

PARALLEL = (
    "bridge_producer_consumer",
    "join_context",
    "rayon::slice::sort",
    "par_sort",
    "rayon::iter::plumbing",
    "rayon_core::scope",
)
IDLE = ("wait_until", "take_local_job", "find_work", "sleep", "steal", "Sleep::")
OURS = ("evogs", "gemm", "faer", "pulp")


def read(path):
    """(thread name, tid, time in s, frames innermost first) per sample."""
    samples, cur = [], None
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if not line.strip():
                if cur:
                    samples.append(cur)
                cur = None
            elif not line.startswith(("\t", " ")) or cur is None:
                m = re.match(r"\s*(\S+)\s+(\d+)\s+([\d.]+):", line)
                cur = (m[1], int(m[2]), float(m[3]), []) if m else None
            else:
                parts = line.strip().split(None, 1)
                frame = parts[1] if len(parts) > 1 else parts[0]
                cur[3].append(re.sub(r"\+0x[0-9a-f]+.*", "", frame))
    if cur:
        samples.append(cur)
    return [s for s in samples if s[0].startswith("evogs-bench")]


def is_idle(frames):
    first_ours = next(
        (i for i, f in enumerate(frames) if any(o in f for o in OURS)), len(frames)
    )
    return any(any(m in f for m in IDLE) for f in frames[:first_ours])


def is_parallel(frames):
    return any(any(m in f for m in PARALLEL) for f in frames)


def key(frames, depth=2):
    ours = [f for f in frames if "evogs" in f and "rayon" not in f and "core::" not in f]
    return " < ".join(f[:60] for f in ours[:depth])


def serial(samples, top):
    kinds, where = collections.Counter(), collections.Counter()
    for _, _, _, frames in samples:
        if is_idle(frames):
            kinds["idle"] += 1
        elif is_parallel(frames):
            kinds["parallel"] += 1
        else:
            kinds["serial"] += 1
            where[key(frames)] += 1
    print("samples:", dict(kinds))
    for k, v in where.most_common(top):
        print(f"{v:6} {k}")


def idle(samples, top):
    by = collections.defaultdict(list)
    for _, tid, t, frames in samples:
        by[tid].append((t, frames))
    tids = list(by)
    if len(tids) != 2:
        sys.exit(f"expected two pool threads, found {len(tids)}")
    times = {tid: [t for t, _ in by[tid]] for tid in tids}
    doing, total = collections.Counter(), 0
    for a in tids:
        b = tids[1] if a == tids[0] else tids[0]
        for t, frames in by[a]:
            if not is_idle(frames):
                continue
            total += 1
            i = bisect.bisect_left(times[b], t)
            near = [j for j in (i - 1, i) if 0 <= j < len(times[b])]
            near = [j for j in near if abs(times[b][j] - t) < 7e-4]
            if not near:
                doing["(no sample of the other thread)"] += 1
                continue
            other = by[b][min(near, key=lambda j: abs(times[b][j] - t))][1]
            doing["(both idle)" if is_idle(other) else key(other) or other[0][:60]] += 1
    print("idle samples:", total)
    for k, v in doing.most_common(top):
        print(f"{v:6} {k}")


def main():
    if len(sys.argv) < 3 or sys.argv[2] not in ("serial", "idle"):
        sys.exit(f"usage: {sys.argv[0]} PERF_SCRIPT_OUTPUT serial|idle [TOP]")
    top = int(sys.argv[3]) if len(sys.argv) > 3 else 30
    samples = read(sys.argv[1])
    (serial if sys.argv[2] == "serial" else idle)(samples, top)


if __name__ == "__main__":
    main()
