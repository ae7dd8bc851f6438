#!/usr/bin/env python3
"""How much of the true rigid motion a trained run reproduces (the README's "x % of the way").

For each rigid body of the `toys` scene (cube and ball by default; torus on request) the script exports the run's Gaussians at
t = 0 and at a few later times (`evogs export`), selects the Gaussians that lie inside the body
at t = 0 (opacity > 0.2) using the ground-truth body-to-world poses of the scene's `meta.json`,
and compares each selected Gaussian's displacement from t = 0 with the displacement the true
rigid motion gives the same point:

- |model|, |gt|: medians of the two displacement lengths;
- cos: median cosine between them (1: the right direction);
- gain: median projection of the model's displacement on the true one, (d_model · d_gt) / |d_gt|²
  (1: the whole motion, 0: none).

Usage (numpy needed; the scene description defaults to `tools/data/toys-meta.json`, a copy of
the `toys` scene's `meta.json`, which also covers `toys-mini`, whose times are a subset):

    python3 tools/motion_gain.py RUN [--meta tools/data/toys-meta.json] [--bodies cube,ball,torus]
                                     [--evogs target/release/evogs] [--times 0.06,0.12,0.25]

It also prints each body's opacity mass at t = 0 (the sum of the opacities of the Gaussians
inside it, whatever their opacity): a body the run has lost shows as a small mass and no
selected Gaussians.
"""

import argparse
import json
import os
import subprocess
import tempfile

import numpy as np


def read_ply(path):
    """The vertex properties of a binary little-endian float32 .ply (as `evogs export` writes)."""
    with open(path, "rb") as f:
        n, props = 0, []
        while True:
            line = f.readline().decode().strip()
            if line.startswith("element vertex"):
                n = int(line.split()[-1])
            elif line.startswith("property"):
                props.append(line.split()[-1])
            elif line == "end_header":
                break
        a = np.frombuffer(f.read(), dtype="<f4").reshape(n, len(props))
    return {k: a[:, i] for i, k in enumerate(props)}


def export(evogs, run, t, tmp):
    out = os.path.join(tmp, "t_%s.ply" % t)
    cmd = [evogs, "export", "--run", run, "--time", repr(t), "--out", out]
    subprocess.run(cmd, check=True, capture_output=True)
    a = read_ply(out)
    return np.stack([a["x"], a["y"], a["z"]], 1), 1.0 / (1.0 + np.exp(-a["opacity"]))


def inside(body, local):
    """Points (body frame) inside the body, with a small margin."""
    if body == "cube":
        return np.abs(local).max(1) < 0.27
    if body == "torus":
        return np.linalg.norm(local, axis=1) < 0.17  # outer radius 0.15
    return np.linalg.norm(local, axis=1) < 0.24  # ball, radius 0.22


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run")
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--meta", default=os.path.join(here, "data", "toys-meta.json"))
    ap.add_argument("--evogs", default="target/release/evogs")
    ap.add_argument("--times", default="0.06,0.12,0.25")
    ap.add_argument("--bodies", default="cube,ball")
    args = ap.parse_args()
    frames = json.load(open(args.meta))["frames"]["train"]
    times = np.array([f["time"] for f in frames])

    def pose(i, body):
        return np.array(frames[i]["objects"][body])

    with tempfile.TemporaryDirectory() as tmp:
        p0, opacity = export(args.evogs, args.run, float(times[0]), tmp)
        homog0 = np.c_[p0, np.ones(len(p0))].T
        bodies = args.bodies.split(",")
        sel, mass = {}, {}
        for b in bodies:
            local = (np.linalg.inv(pose(0, b)) @ homog0).T[:, :3]
            within = inside(b, local)
            sel[b] = within & (opacity > 0.2)
            mass[b] = float(opacity[within].sum())
        print("Gaussians per body:", {b: int(m.sum()) for b, m in sel.items()})
        print("opacity mass per body:", {b: round(m, 1) for b, m in mass.items()})
        for want in (float(s) for s in args.times.split(",")):
            i = int(np.argmin(np.abs(times - want)))
            p, _ = export(args.evogs, args.run, float(times[i]), tmp)
            row = []
            for b in bodies:
                m = sel[b]
                if not m.any():
                    row.append("%s: no Gaussian with opacity > 0.2" % b)
                    continue
                moved = pose(i, b) @ np.linalg.inv(pose(0, b)) @ homog0[:, m]
                d_gt = moved[:3].T - p0[m]
                d_model = p[m] - p0[m]
                dot = (d_model * d_gt).sum(1)
                n_gt, n_model = np.linalg.norm(d_gt, axis=1), np.linalg.norm(d_model, axis=1)
                cos = dot / (n_model * n_gt + 1e-12)
                gain = dot / (n_gt * n_gt + 1e-12)
                row.append(
                    "%s |model| %.3f |gt| %.3f cos %.2f gain %.2f"
                    % (b, np.median(n_model), np.median(n_gt), np.median(cos), np.median(gain))
                )
            print("t = %.3f  " % times[i] + "   ".join(row))


if __name__ == "__main__":
    main()
